"""The occluder family: shadow rays that graze and cross an occluder near their origin, at every
scale from 1e3 to 1e7 (issue: a shadow ray at 1e6 was reported lit while passing 0.10 units
inside an opaque sphere 0.69 units from its hit point).

Each scene is written in units of U, the float32 spacing at the translation T, so the same
geometry sits at the same number of ulps at every scale: a receiver (a floor, or a fat cone
whose top surface slopes), an occluder of one kind (sphere, open cylinder, open cone, plate)
whose near surface is 11 U above the receiver — several times the secondary-ray offset's bound
there, as in the report (0.69 units = 11 U at 1e6) — radius 8 U, a light high and to the side,
and the eye looking down at the occluder's shadow edge, so the eye hits' shadow rays pass the
occluder at depths from outside it to 20 U inside (a sample every ~3–4 U). Every coordinate is
T + k·U with an integer k: exact in float32 and float64. The judge is numerics' (`judge`: the
float64 oracle from the path's own hit point against the offset's bound); the machine must equal
golden fp32.
"""

from __future__ import annotations

import numpy as np

from netsushisen.numerics import Case

KINDS = ("sphere", "cylinder", "cone", "polygon")
RECEIVERS = ("floor", "cone")
SCALES = (1e3, 1e4, 1e5, 1e6, 1e7)
LIGHT = (150, 400, -100)  # in U: high, to the side
RADIUS, CENTRE_HEIGHT = 8, 19  # in U: the near surface 11 U above y = 0


def unit(translation: float) -> float:
    """U: the float32 spacing at `translation`."""
    return float(np.spacing(np.float32(translation)))


def occluder_nff(kind: str, translation: float, receiver: str = "floor") -> str:
    """The untranslated scene (coordinates k·U; `numerics.translate_nff` adds T exactly)."""
    U = unit(translation)
    k = lambda *v: " ".join(repr(float(x) * U) for x in v)  # noqa: E731
    light = np.array(LIGHT, float)
    centre = np.array([0.0, CENTRE_HEIGHT, 0.0])
    shadow = centre + (centre - light) * (CENTRE_HEIGHT / (light[1] - CENTRE_HEIGHT))
    edge = np.round(shadow + [RADIUS, 0, 0])  # where the shadow's edge crosses y = 0 (about)
    text = (f"b 0.1 0.2 0.3\nv\nfrom {k(edge[0], 60, edge[2] - 60)}\nat {k(edge[0], 0, edge[2])}\n"
            f"up 0 1 0\nangle 40\nhither 0\nresolution 8 8\nl {k(*light)}\nf 0.8 0.8 0.8 0.8 0 1 0 0\n")
    if receiver == "floor":
        text += "p 4\n" + "".join(f"{k(*p)}\n" for p in [(-160, 0, -160), (-160, 0, 160), (160, 0, 160),
                                                          (160, 0, -160)])
    elif receiver == "cone":  # its top runs from y = 0 to y = 8 along x: a sloping normal
        text += f"c {k(-160, -120, 0)} {120 * U!r} {k(160, -120, 0)} {128 * U!r}\n"
    else:
        raise ValueError(f"receiver must be one of {', '.join(RECEIVERS)}, got {receiver!r}")
    text += "f 1 0.5 0.2 0.8 0.2 10 0 0\n"
    r, h = RADIUS, CENTRE_HEIGHT
    if kind == "sphere":
        text += f"s {k(0, h, 0)} {r * U!r}\n"
    elif kind == "cylinder":
        text += f"c {k(0, h, -24)} {r * U!r} {k(0, h, 24)} {r * U!r}\n"
    elif kind == "cone":
        text += f"c {k(0, h, -24)} {r * U!r} {k(0, h, 24)} {r / 2 * U!r}\n"
    elif kind == "polygon":  # a plate at the others' near surface
        text += "p 4\n" + "".join(f"{k(*p)}\n" for p in [(-r, h - r, -24), (r, h - r, -24), (r, h - r, 24),
                                                          (-r, h - r, 24)])
    else:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
    return text


def occluder_case(kind: str, translation: float, receiver: str = "floor", res: int = 16) -> Case:
    """One member of the family as a numerics catalog case."""
    return Case(f"occluder_{kind}_on_{receiver}_{translation:.0e}".replace("+0", ""),
                f"shadow rays grazing and crossing a {kind} 11 ulps above a {receiver}, moved by "
                f"{translation:g}", occluder_nff(kind, translation, receiver), res=res,
                translate=translation)


def family(scales=SCALES, kinds=KINDS, receivers=RECEIVERS, res: int = 16) -> list[Case]:
    return [occluder_case(k, t, r, res) for t in scales for k in kinds for r in receivers]


def sphere_depths(case: Case, points: np.ndarray, lights: np.ndarray) -> np.ndarray:
    """How deep (in U, positive inside) each shadow ray from `points` (n, 3) to `lights` (n, 3)
    passes inside the family's sphere, in float64: radius − distance of the segment to the
    centre. The family's own check that it covers the depths it claims to."""
    U = unit(case.translate)
    centre = np.array([0.0, CENTRE_HEIGHT * U, 0.0]) + case.translate
    d = lights - points
    s = np.clip(((centre - points) * d).sum(axis=1) / (d * d).sum(axis=1), 0.0, 1.0)
    closest = points + s[:, None] * d
    return (RADIUS * U - np.sqrt(((closest - centre) ** 2).sum(axis=1))) / U
