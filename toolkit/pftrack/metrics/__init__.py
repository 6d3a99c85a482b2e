"""pftrack.metrics"""
