"""pftrack.scenes"""
