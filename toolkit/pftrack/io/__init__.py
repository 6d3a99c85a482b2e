"""Reading and writing tracks, sequences and outputs."""
