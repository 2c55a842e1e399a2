"""The floor: a bare compiled-regex tokenizer pass (letter + number words, float conversion),
reading line by line. What no parser can beat by much; postproc is measured against it.
The loop runs in a function, where names are fast locals: the floor is as quick as this
simple pass can be written."""

import re
import sys

WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")


def main(path: str) -> int:
    findall = WORD.findall
    count = 0
    with open(path) as program:
        for line in program:
            for letter, value in findall(line):
                float(value)
            count += 1
    return count


print(main(sys.argv[1]))
