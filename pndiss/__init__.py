"""pndiss: PROFINET encoder dissector and log analyzer."""
__version__ = "0.1.0"
