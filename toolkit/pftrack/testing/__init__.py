"""pftrack.testing"""
