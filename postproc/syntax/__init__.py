"""Bytes to lossless blocks: the source, the fast path, the grammar path, the reader and Macro B values."""
