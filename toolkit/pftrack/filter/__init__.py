"""pftrack.filter"""
