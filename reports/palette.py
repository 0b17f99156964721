"""The colours of the paper report's plots, in one place, so that one thing has one colour in
every figure: a scene is the same colour in Figures 3 and 4, a local-memory size the same colour
in Figure 5 and in the ρ / miss-rate plots, and the paper's claims are always black.

Scenes take the Okabe–Ito palette (distinguishable with the common colour-vision deficiencies);
local-memory sizes a light-to-dark blue ramp (a larger memory is darker), so a scene colour is
never mistaken for a size. Each series also has its own line style and marker (`style`), so the
figures read in grey print too.
"""

from __future__ import annotations

SCENE_COLOURS = ("#E69F00", "#0072B2", "#009E73", "#D55E00", "#CC79A7", "#56B4E9", "#F0E442",
                 "#000000")
LOCAL_COLOURS = ("#9ecae1", "#4292c6", "#08306b")
PAPER = {"color": "black", "linewidth": 1.2, "linestyle": (0, (2, 2))}
"""The paper's claims: black, dashed (or a hatched band)."""
LINESTYLES = ("-", "--", "-.", (0, (1, 1)), (0, (5, 1, 1, 1, 1, 1)))
MARKERS = ("o", "s", "^", "D", "v")


def scene_colour(i: int) -> str:
    """The i-th scene's colour (scenes in the order the run was given)."""
    return SCENE_COLOURS[i % len(SCENE_COLOURS)]


def local_colour(i: int) -> str:
    """The i-th local-memory size's colour (LOCAL_SHARES order: 10 %, 30 %, 50 %)."""
    return LOCAL_COLOURS[i % len(LOCAL_COLOURS)]


def style(i: int) -> dict:
    """Line style and marker of the i-th series (grey print)."""
    return {"linestyle": LINESTYLES[i % len(LINESTYLES)], "marker": MARKERS[i % len(MARKERS)]}
