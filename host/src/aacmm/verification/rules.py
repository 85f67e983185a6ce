"""Maximum permissible errors and decision rules.

Two decision rules, named in the plan and stated in every report:

- ``simple``: simple acceptance (ILAC-G8 "simple acceptance", ISO 14253-5
  style): a value conforms when it does not exceed the MPE. The test's
  uncertainty is reported but not used.
- ``iso14253-1``: ISO 14253-1 proof of conformance, the supplier's rule for
  acceptance tests: the conformance zone is the specification zone reduced by
  the test's expanded uncertainty U, so a value passes only when it does not
  exceed MPE - U. A value above MPE + U proves non-conformance; a value in
  between proves neither and, under this rule, does not pass.

Every compared value is a non-negative magnitude (|P_Size|, P_Form, |E|, ...).
The MPEs themselves come from the plan (:class:`aacmm.plans.Mpe`; the length
dependent MPE of E_Uni is :class:`aacmm.plans.EUniMpe`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

RULES: tuple[str, ...] = ("simple", "iso14253-1")

PASS = "PASS"
FAIL = "FAIL"
NO_MPE = "NO MPE"

CONFORMANCE = "conformance proved"
NONCONFORMANCE = "non-conformance proved"
UNDECIDED = "neither proved (within U of the MPE)"


@dataclass(frozen=True)
class Decision:
    """The verdict on one value.

    ``value`` (mm, >= 0) is compared with ``mpe`` (mm, None when the plan
    gives none) under ``rule``, with ``u`` the test's expanded uncertainty
    (k = 2, mm). ``limit`` is the acceptance limit actually used (MPE or
    MPE - U). ``zone`` is the ISO 14253-1 classification whatever the rule.
    """

    rule: str
    value: float
    mpe: float | None
    u: float
    limit: float | None
    verdict: str
    zone: str

    @property
    def passed(self) -> bool:
        return self.verdict == PASS

    @property
    def failed(self) -> bool:
        return self.verdict == FAIL


def check_rule(rule: str) -> str:
    """``rule`` if it is one of :data:`RULES`, else ValueError."""
    if rule not in RULES:
        raise ValueError(f"unknown decision rule {rule!r} (use one of: {', '.join(RULES)})")
    return rule


def decide(value: float, mpe: float | None, u: float, rule: str) -> Decision:
    """Judge a magnitude ``value`` against ``mpe`` with uncertainty ``u`` under ``rule``.

    Raises:
        ValueError: unknown rule, negative or non-finite ``u``, or a guard band
            (``iso14253-1``) at least as large as the MPE (no value could pass).
    """
    check_rule(rule)
    if not (math.isfinite(u) and u >= 0.0):
        raise ValueError(f"the test uncertainty must be finite and >= 0 mm, got {u}")
    if mpe is None:
        return Decision(rule, value, None, u, None, NO_MPE, "")
    if rule == "iso14253-1" and u >= mpe:
        raise ValueError(
            f"the test uncertainty U = {u:.4f} mm is not smaller than the MPE {mpe:.4f} mm: "
            "the ISO 14253-1 conformance zone is empty"
        )
    if not math.isfinite(value):
        return Decision(rule, value, mpe, u, None, FAIL, NONCONFORMANCE)
    if value <= mpe - u:
        zone = CONFORMANCE
    elif value > mpe + u:
        zone = NONCONFORMANCE
    else:
        zone = UNDECIDED
    limit = mpe if rule == "simple" else mpe - u
    return Decision(rule, value, mpe, u, limit, PASS if value <= limit else FAIL, zone)


def overall(decisions: list[Decision]) -> str:
    """FAIL if any decision fails; PASS if at least one passes and none fails; else NO MPE."""
    if any(d.failed for d in decisions):
        return FAIL
    if any(d.passed for d in decisions):
        return PASS
    return NO_MPE
