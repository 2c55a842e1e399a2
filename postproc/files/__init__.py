"""What postproc reads and writes: input files read once and bounded, outputs written whole or not at all."""
