"""The floor: a bare compiled-regex tokenizer pass (letter + number words, float conversion),
reading line by line. What no parser can beat by much; postproc is measured against it."""

import re
import sys

WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")

count = 0
with open(sys.argv[1]) as program:
    for line in program:
        for letter, value in WORD.findall(line):
            float(value)
        count += 1
print(count)
