"""The seven parameter sets of the thesis (docs/model.md §2.5) and its base-case result.

Only the base case's α and β were used to fix anything (the default pressure,
``isj.design.DEFAULT_PRESSURE_PA``); the other six are predictions.
"""

from __future__ import annotations

from dataclasses import dataclass

from .design import Materials


@dataclass(frozen=True)
class ThesisCase:
    """A named set of pedicle, gap and capsule moduli (Pa)."""

    name: str
    pedicle_e_pa: float
    gap_e_pa: float
    capsule_e_pa: float

    def materials(self, base: Materials | None = None) -> Materials:
        """``base`` (default materials) with this case's three moduli."""
        return (base or Materials()).replace(
            pedicle_e_pa=self.pedicle_e_pa, gap_e_pa=self.gap_e_pa, capsule_e_pa=self.capsule_e_pa
        )


THESIS_CASES: tuple[ThesisCase, ...] = (
    ThesisCase("base", 5e9, 10e6, 50e6),
    ThesisCase("j5", 5e9, 5e6, 50e6),
    ThesisCase("c20", 5e9, 10e6, 20e6),
    ThesisCase("c100", 5e9, 10e6, 100e6),
    ThesisCase("j5c20", 5e9, 5e6, 20e6),
    ThesisCase("p12", 12e9, 10e6, 50e6),
    ThesisCase("p3", 3e9, 10e6, 50e6),
)

#: Thesis Table 7.2, base case (rad).
THESIS_BASE_ALPHA_RAD = 1.663e-6
THESIS_BASE_BETA_RAD = 11.77e-6
THESIS_BASE_SUM_RAD = 13.433e-6

#: Linear tetrahedra in the thesis's pedicle-and-joint model (thesis §7.1).
THESIS_N_TETS = 13209


def case_by_name(name: str) -> ThesisCase:
    for c in THESIS_CASES:
        if c.name == name:
            return c
    raise KeyError(f"case = {name!r}: must be one of {', '.join(c.name for c in THESIS_CASES)}")
