"""Converts two fishmechr data sets to shoal's midline CSV (`t,point,x,y`).

Source: tytell/fishmechr (GitHub; CRAN package fishmechr 1.0.3), commit 6655ac9, by Eric Tytell
and Olivia Hawkins, licensed CC BY 4.0 (https://creativecommons.org/licenses/by/4.0/).
See README.md beside this script for what was changed.

Usage (needs the `rdata` package from PyPI, `pip install rdata`):
    python3 convert_fishmechr.py FISHMECHR_CHECKOUT
reads FISHMECHR_CHECKOUT/data/{lampreydata,zfishdata}.rda and writes lamprey.csv and
zebrafish_060rpm.csv here.
"""

import os
import sys
import warnings

import numpy as np
import rdata

HERE = os.path.dirname(os.path.abspath(__file__))
# Midline keypoints of the zebrafish, head to tail (on the ventral midline, with the fewest gaps;
# the tail tip is the dorsal caudal lobe's tip, which has 4 gaps in these frames where the ventral
# lobe's has many more).
ZFISH_POINTS = ["snout", "hyoid", "pelvic_fin_base", "anus", "peduncle", "dorsal_caudal"]
ZFISH_FPS = 50.0  # "fps <- 50" in vignettes/process_sleap_data.Rmd
# The 60 RPM trial's first block of good frames (data-raw/zfish_goodframes.csv: 48-135), the
# longest stretch of steady swimming at one flow speed.
ZFISH_TRIAL = "060RPM"
ZFISH_FRAMES = (48, 135)


def read(path, name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return rdata.read_rda(path)[name]


def lamprey(root, out):
    d = read(os.path.join(root, "data", "lampreydata.rda"), "lampreydata")
    # Frames 1 and 2 are empty (NaN): dropped. Nothing else changed.
    d = d.dropna().sort_values(["frame", "point"])
    with open(out, "w") as f:
        f.write("t,point,x,y\n")
        for r in d.itertuples():
            f.write(f"{r.t:.2f},{int(r.point)},{r.mxmm:.3f},{r.mymm:.3f}\n")


def zebrafish(root, out):
    d = read(os.path.join(root, "data", "zfishdata.rda"), "zfishdata")
    d = d[d.fn.str.contains(ZFISH_TRIAL)].sort_values("frame_idx")
    d = d[(d.frame_idx >= ZFISH_FRAMES[0]) & (d.frame_idx <= ZFISH_FRAMES[1])]
    frames = d.frame_idx.to_numpy()
    assert (np.diff(frames) == 1).all(), "frames are consecutive"
    cols = {}
    for p in ZFISH_POINTS:
        for c in ("x", "y"):
            v = d[f"{p}.{c}"].to_numpy(dtype=float).copy()
            # Gaps (untracked frames) filled linearly in time.
            bad = np.isnan(v)
            v[bad] = np.interp(frames[bad], frames[~bad], v[~bad])
            cols[(p, c)] = v
    with open(out, "w") as f:
        f.write("t,point,x,y\n")
        for k, fr in enumerate(frames):
            for i, p in enumerate(ZFISH_POINTS):
                # Image rows grow downwards: y is negated so that x-y is counterclockwise.
                f.write(
                    f"{fr / ZFISH_FPS:.2f},{i + 1},{cols[(p, 'x')][k]:.2f},"
                    f"{-cols[(p, 'y')][k]:.2f}\n"
                )


if __name__ == "__main__":
    root = sys.argv[1]
    lamprey(root, os.path.join(HERE, "lamprey.csv"))
    zebrafish(root, os.path.join(HERE, "zebrafish_060rpm.csv"))
