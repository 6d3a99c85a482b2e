"""pftrack.render"""
