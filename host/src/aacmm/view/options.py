"""The live view's settings and their limits (light: the command line reads them)."""

from __future__ import annotations

#: Frames a second the feed makes by default, and the range allowed.
FPS_DEFAULT = 40
FPS_RANGE = (30, 120)
#: Tip positions kept in the trail by default.
TRAIL_DEFAULT = 400
