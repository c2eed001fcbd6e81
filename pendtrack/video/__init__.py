"""Video I/O edges: decoding (reader) and H.264 encoding (writer)."""
