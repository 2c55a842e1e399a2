"""Blocks to moves: what each G code means, the interpreter, corners, and a program read and interpreted."""
