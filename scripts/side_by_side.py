#!/usr/bin/env python3
"""Paste PNGs left to right with a 4-pixel white gap: side_by_side.py OUT.png IN1.png IN2.png ...
(needs Pillow: pip install pillow)."""
import sys

from PIL import Image

ims = [Image.open(p).convert("RGB") for p in sys.argv[2:]]
w = sum(i.width for i in ims) + 4 * (len(ims) - 1)
h = max(i.height for i in ims)
out = Image.new("RGB", (w, h), (255, 255, 255))
x = 0
for i in ims:
    out.paste(i, (x, 0))
    x += i.width + 4
out.save(sys.argv[1])
