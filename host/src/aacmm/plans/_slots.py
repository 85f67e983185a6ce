"""The slots of a plan: every point it asks for, in order, with labels, prompt and target."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from aacmm.plans import presets
from aacmm.plans.model import (
    ENDS,
    Artefact,
    LengthStandard,
    Plane,
    Probe,
    Slot,
    Sphere,
    Step,
    Target,
    Vec3,
)

PRESET_ISO = "iso10360-12"
ARTEFACT_WORDS = {
    "cone": "cone",
    "sphere": "sphere",
    "ballbar": "ball bar",
    "gauge": "gauge",
    "plane": "plane",
    "part": "part",
}


def _v(a: Any) -> Vec3:
    x, y, z = (float(e) for e in np.asarray(a, dtype=np.float64).reshape(3))
    return (x, y, z)


def make_slots(
    steps: tuple[Step, ...], artefacts: dict[str, Artefact], probe: Probe
) -> tuple[Slot, ...]:
    out: list[Slot] = []
    n_steps = len(steps)
    r = probe.ball_radius_mm
    for st in steps:
        art = artefacts.get(st.artefact) if st.artefact is not None else None
        head = f"step {st.index + 1}/{n_steps}, " + (
            f"{ARTEFACT_WORDS[art.type]} {art.id}" if art is not None else "free points"
        )
        loc = None if art is None or art.location_mm is None else np.array(art.location_mm)

        def add(
            k: int,
            text: str,
            target: Target | None,
            pos: int | None = None,
            end: str | None = None,
            artic: int | None = None,
            _st: Step = st,
            _head: str = head,
        ) -> None:
            out.append(
                Slot(
                    index=len(out),
                    step_index=_st.index,
                    step_id=_st.id,
                    procedure=_st.procedure,
                    artefact=_st.artefact,
                    point_index=k,
                    position_index=pos,
                    end=end,
                    articulation_index=artic,
                    target=target,
                    text=f"{_head}, {text}",
                )
            )

        if st.procedure == "cone":
            for k in range(st.points):
                tgt = None if loc is None else Target(_v(loc), None, _v(loc))
                add(k, f"articulation {k + 1} of {st.points}: seat the probe", tgt, artic=k)
        elif st.procedure == "sphere":
            assert isinstance(art, Sphere)
            dirs = (
                presets.iso10360_sphere_25(art.pole)
                if st.preset == PRESET_ISO
                else presets.spiral_cap(st.points, art.pole, st.max_polar_deg or 90.0)
            )
            for k, d in enumerate(dirs):
                polar = math.degrees(math.acos(max(-1.0, min(1.0, float(d @ art.pole)))))
                tgt = None
                if loc is not None:
                    tgt = Target(_v(loc + (art.radius_mm + r) * d), _v(d), _v(loc))
                add(k, f"point {k + 1} of {st.points} ({polar:.1f} deg from the pole)", tgt)
        elif st.procedure == "length":
            assert isinstance(art, LengthStandard)
            m, kk = st.position_count or 0, st.points_per_end or 1
            k = 0
            for p in range(m):
                for end in ENDS:
                    for j in range(kk):
                        tgt = None
                        if st.positions is not None:
                            pos = st.positions[p]
                            centre = np.array(pos.end_mm(end))
                            if art.ends == "cone":
                                tgt = Target(_v(centre), None, _v(centre))
                            else:
                                outward = np.array(pos.direction) * (1.0 if end == "B" else -1.0)
                                d = presets.ring_pattern(kk, outward)[j]
                                rad = (art.end_diameter_mm or 0.0) / 2.0 + r
                                tgt = Target(_v(centre + rad * d), _v(d), _v(centre))
                        what = f"probe end {end}"
                        if kk > 1:
                            what = f"end {end}, point {j + 1} of {kk}"
                        add(k, f"position {p + 1} of {m}: {what}", tgt, pos=p, end=end)
                        k += 1
        elif st.procedure == "articulation":
            n, m = st.articulations or 0, st.points_per_articulation or 1
            ring = presets.ring_pattern(m, art.pole) if isinstance(art, Sphere) else None
            for a in range(n):
                for j in range(m):
                    tgt = None
                    if loc is not None and ring is not None:
                        assert isinstance(art, Sphere)
                        d = ring[j]
                        tgt = Target(_v(loc + (art.radius_mm + r) * d), _v(d), _v(loc))
                    elif loc is not None:
                        tgt = Target(_v(loc), None, _v(loc))
                    what = f"articulation {a + 1} of {n}"
                    what += f", point {j + 1} of {m}" if m > 1 else ": seat the probe"
                    add(a * m + j, what, tgt, artic=a)
        elif st.procedure == "plane":
            assert isinstance(art, Plane)
            offs, nrm = presets.plane_grid(st.points, art.normal, art.size_mm)
            for k in range(st.points):
                tgt = None
                if loc is not None:
                    on = loc + offs[k]
                    tgt = Target(_v(on + r * nrm), _v(nrm), _v(on))
                add(k, f"point {k + 1} of {st.points}", tgt)
        else:
            for k in range(st.points):
                tgt = None
                if st.targets_mm is not None:
                    tgt = Target(st.targets_mm[k], None, st.targets_mm[k])
                add(k, f"point {k + 1} of {st.points}", tgt)
    return tuple(out)
