"""The peers, run in the benchmark's own environment: pygcode and gcodeparser on one file."""

import sys


def pygcode(path: str) -> int:
    from pygcode import Line

    count = 0
    with open(path) as program:
        for text in program:
            Line(text)
            count += 1
    return count


def gcodeparser(path: str) -> int:
    from gcodeparser import GcodeParser

    with open(path) as program:
        return len(GcodeParser(program.read()).lines)


if __name__ == "__main__":
    print({"pygcode": pygcode, "gcodeparser": gcodeparser}[sys.argv[1]](sys.argv[2]))
