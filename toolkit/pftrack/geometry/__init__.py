"""pftrack.geometry"""
