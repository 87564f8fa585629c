"""Inputs of ``isj uq``: a distribution per Young's modulus (Pa), counts and seed (docs/uq.md §11.2).

The default is log-uniform over the calibrated domain of the lumped model (the shipped
calibration's ``domain``: the thesis's plausible ranges, docs/lumped.md §3.5, thesis
§6.2.3–6.2.5); a ``[uq]`` TOML section changes any modulus to another log-uniform range, a
lognormal (median and σ of ln E, or a factor F = e^σ) or a fixed value. Bad values raise
:class:`isj.errors.ConfigError` in one line naming the key and its range.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from isj.design import Materials
from isj.errors import ConfigError
from isj.lumped.model import MODULI
from isj.validate import (
    MODULUS_RANGE_PA,
    TRANSMISSION_SAMPLES_RANGE,
    TRANSMISSION_SOBOL_SAMPLES_RANGE,
    read_toml,
)

#: Distribution kinds.
KINDS = ("loguniform", "lognormal", "fixed")
#: Defaults: 10^6 Monte Carlo draws; 2^14 Saltelli base samples (2^14 (d + 2) model runs);
#: 100 bootstrap resamples (SALib's own default).
DEFAULT_SAMPLES = 1_000_000
DEFAULT_SOBOL_SAMPLES = 2**14
DEFAULT_BOOTSTRAP = 100
#: ΔH_V through the fast ear (docs/uq.md §11.10): its Monte Carlo draws (the first of the α/β
#: draws) and Saltelli base samples, and their ranges.
DEFAULT_TRANSMISSION_SAMPLES = 20_000
DEFAULT_TRANSMISSION_SOBOL_SAMPLES = 2**10
#: Ranges of the counts: [lo, hi] (Sobol' base samples: also a power of 2).
SAMPLES_RANGE = (1_000, 10_000_000)
SOBOL_SAMPLES_RANGE = (2**6, 2**18)
BOOTSTRAP_RANGE = (10, 10_000)
SEED_RANGE = (0, 2**32 - 1)
#: Largest sobol_samples × bootstrap: SALib's bootstrap holds arrays of that many float64 values
#: (2^24: 134 MB each, about 30 s per output on one core).
MAX_BOOTSTRAP_DRAWS = 2**24
#: Largest σ of ln E of a lognormal (a factor e^3 ≈ 20 per standard deviation).
MAX_SIGMA_LN = 3.0
#: Φ⁻¹(1 − 0.001): a lognormal's 0.1 % and 99.9 % quantiles must lie in the modulus range.
_Z999 = 3.090232306167813


def _in_range(where: str, value, lo: float, hi: float, unit: str = "", lo_open: bool = False) -> float:
    """``value`` as a finite float in [lo, hi] (or (lo, hi]), else a ConfigError naming ``where`` and the
    range."""
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or not (lo < value if lo_open else lo <= value) or not value <= hi:
        rng = f"{'(' if lo_open else '['}{lo:.6g}, {hi:.6g}]"
        raise ConfigError(f"{where} = {value!r}: must be a number in {rng}{unit}")
    return float(value)


@dataclass(frozen=True)
class Distribution:
    """The distribution of one Young's modulus (Pa).

    Parameters
    ----------
    kind : ``"loguniform"`` (``low_pa``, ``high_pa``), ``"lognormal"`` (``median_pa``,
        ``sigma_ln``: the standard deviation of ln E; a factor F is σ = ln F) or ``"fixed"``
        (``value_pa``)
    """

    kind: str
    low_pa: float = math.nan
    high_pa: float = math.nan
    median_pa: float = math.nan
    sigma_ln: float = math.nan
    value_pa: float = math.nan
    name: str = "modulus"

    def __post_init__(self):
        w, (lo, hi) = f"uq.{self.name}", MODULUS_RANGE_PA
        if self.kind not in KINDS:
            raise ConfigError(f"{w}.distribution = {self.kind!r}: must be one of {', '.join(KINDS)}")
        if self.kind == "loguniform":
            a = _in_range(f"{w}.low_pa", self.low_pa, lo, hi, " Pa")
            _in_range(f"{w}.high_pa", self.high_pa, a, hi, " Pa (above low_pa)", lo_open=True)
        elif self.kind == "lognormal":
            m = _in_range(f"{w}.median_pa", self.median_pa, lo, hi, " Pa")
            s = _in_range(f"{w}.sigma_ln", self.sigma_ln, 0.0, MAX_SIGMA_LN, lo_open=True)
            if not (lo <= m * math.exp(-_Z999 * s) and m * math.exp(_Z999 * s) <= hi):
                raise ConfigError(
                    f"{w}.sigma_ln = {s:g}: its 0.1-99.9 % range {m * math.exp(-_Z999 * s):.3g}.."
                    f"{m * math.exp(_Z999 * s):.3g} Pa leaves [{lo:g}, {hi:g}] Pa"
                )
        else:
            _in_range(f"{w}.value_pa", self.value_pa, lo, hi, " Pa")

    @classmethod
    def loguniform(cls, low_pa: float, high_pa: float, name: str = "modulus") -> Distribution:
        """Uniform in ln E on [low_pa, high_pa] (Pa)."""
        return cls("loguniform", low_pa=low_pa, high_pa=high_pa, name=name)

    @classmethod
    def lognormal(cls, median_pa, sigma_ln=None, factor=None, name: str = "modulus") -> Distribution:
        """ln E normal about ln(median_pa), with σ = ``sigma_ln`` or ln(``factor``) (exactly one)."""
        w = f"uq.{name}"
        if (sigma_ln is None) == (factor is None):
            raise ConfigError(f"{w}: a lognormal needs exactly one of sigma_ln (of ln E) or factor (> 1)")
        if factor is not None:
            f = _in_range(f"{w}.factor", factor, 1.0, math.exp(MAX_SIGMA_LN), lo_open=True)
            sigma_ln = math.log(f)
        return cls("lognormal", median_pa=median_pa, sigma_ln=sigma_ln, name=name)

    @classmethod
    def fixed(cls, value_pa: float, name: str = "modulus") -> Distribution:
        """No uncertainty: E = value_pa (Pa)."""
        return cls("fixed", value_pa=value_pa, name=name)

    @classmethod
    def from_table(cls, name: str, table) -> Distribution:
        """From a ``[uq.<name>]`` TOML table: ``distribution`` and the keys of that kind."""
        w = f"uq.{name}"
        if not isinstance(table, dict):
            raise ConfigError(f"{w} = {table!r}: must be a table [uq.{name}] with a 'distribution' key")
        keys = {
            "loguniform": {"low_pa", "high_pa"},
            "lognormal": {"median_pa", "sigma_ln", "factor"},
            "fixed": {"value_pa"},
        }
        kind = table.get("distribution")
        if kind not in KINDS:
            raise ConfigError(f"{w}.distribution = {kind!r}: must be one of {', '.join(KINDS)}")
        extra = sorted(set(table) - keys[kind] - {"distribution"})
        if extra:
            raise ConfigError(
                f"{w}.{extra[0]}: unknown key for {kind}; valid: {', '.join(sorted(keys[kind]))}"
            )
        need = {"loguniform": ("low_pa", "high_pa"), "lognormal": ("median_pa",), "fixed": ("value_pa",)}
        for k in need[kind]:
            if k not in table:
                raise ConfigError(f"{w}.{k}: missing (a {kind} needs {', '.join(need[kind])})")
        if kind == "loguniform":
            return cls.loguniform(table["low_pa"], table["high_pa"], name)
        if kind == "lognormal":
            return cls.lognormal(table["median_pa"], table.get("sigma_ln"), table.get("factor"), name)
        return cls.fixed(table["value_pa"], name)

    @property
    def uncertain(self) -> bool:
        return self.kind != "fixed"

    def ppf(self, u) -> np.ndarray:
        """The inverse CDF: moduli (Pa) at probabilities ``u`` in [0, 1] (0 and 1 clipped inwards)."""
        u = np.asarray(u, dtype=float)
        if self.kind == "loguniform":
            a = math.log(self.low_pa)
            return np.exp(a + u * (math.log(self.high_pa) - a))
        if self.kind == "lognormal":
            from scipy.special import ndtri

            tiny = np.finfo(float).eps / 2
            return self.median_pa * np.exp(self.sigma_ln * ndtri(np.clip(u, tiny, 1 - tiny)))
        return np.full(u.shape, self.value_pa)

    def to_dict(self) -> dict:
        """The TOML/JSON table: ``distribution`` and its parameters (SI)."""
        if self.kind == "loguniform":
            return {"distribution": self.kind, "low_pa": self.low_pa, "high_pa": self.high_pa}
        if self.kind == "lognormal":
            return {
                "distribution": self.kind,
                "median_pa": self.median_pa,
                "sigma_ln": self.sigma_ln,
                "factor": math.exp(self.sigma_ln),
            }
        return {"distribution": self.kind, "value_pa": self.value_pa}


def _count(where: str, value, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise ConfigError(f"{where} = {value!r}: must be an integer in [{lo}, {hi}]")
    return value


@dataclass(frozen=True)
class UQConfig:
    """Distributions of every modulus in :data:`isj.lumped.model.MODULI`, counts and seed.

    Parameters
    ----------
    distributions : modulus name → :class:`Distribution` (every name of MODULI)
    samples : Monte Carlo draws, in :data:`SAMPLES_RANGE`
    sobol_samples : Saltelli base samples N, a power of 2 in :data:`SOBOL_SAMPLES_RANGE`
        (N (d + 2) model runs for d uncertain moduli)
    bootstrap : bootstrap resamples of the Sobol' indices, in :data:`BOOTSTRAP_RANGE`
    seed : of the Monte Carlo draws, the scrambled Sobol' points and the bootstrap
    transmission : also ΔH_V through the fast ear (docs/uq.md §11.10); None: the command's default
    transmission_samples : its Monte Carlo draws (the first of the α/β draws), in
        :data:`TRANSMISSION_SAMPLES_RANGE`
    transmission_sobol_samples : its Saltelli base samples, a power of 2 in
        :data:`TRANSMISSION_SOBOL_SAMPLES_RANGE`
    """

    distributions: dict[str, Distribution]
    samples: int = DEFAULT_SAMPLES
    sobol_samples: int = DEFAULT_SOBOL_SAMPLES
    bootstrap: int = DEFAULT_BOOTSTRAP
    seed: int = 0
    transmission: bool | None = None
    transmission_samples: int = DEFAULT_TRANSMISSION_SAMPLES
    transmission_sobol_samples: int = DEFAULT_TRANSMISSION_SOBOL_SAMPLES

    def __post_init__(self):
        if set(self.distributions) != set(MODULI):
            raise ConfigError(f"distributions: must name every modulus {', '.join(MODULI)}")
        _count("uq.samples", self.samples, *SAMPLES_RANGE)
        n = _count("uq.sobol_samples", self.sobol_samples, *SOBOL_SAMPLES_RANGE)
        if n & (n - 1):
            raise ConfigError(f"uq.sobol_samples = {n}: must be a power of 2 (Sobol' balance), e.g. {2**14}")
        _count("uq.bootstrap", self.bootstrap, *BOOTSTRAP_RANGE)
        if n * self.bootstrap > MAX_BOOTSTRAP_DRAWS:
            raise ConfigError(
                f"uq.sobol_samples x uq.bootstrap = {n} x {self.bootstrap}: must be <= {MAX_BOOTSTRAP_DRAWS} "
                "(memory of SALib's bootstrap); lower --sobol-samples or --bootstrap"
            )
        _count("uq.seed", self.seed, *SEED_RANGE)
        if self.transmission is not None and not isinstance(self.transmission, bool):
            raise ConfigError(f"uq.transmission = {self.transmission!r}: must be true or false")
        check_count("transmission_samples", self.transmission_samples)
        t = check_count("transmission_sobol_samples", self.transmission_sobol_samples)
        if t * self.bootstrap > MAX_BOOTSTRAP_DRAWS:
            raise ConfigError(
                f"uq.transmission_sobol_samples x uq.bootstrap = {t} x {self.bootstrap}: must be <= "
                f"{MAX_BOOTSTRAP_DRAWS} (memory of SALib's bootstrap)"
            )
        if not self.uncertain:
            raise ConfigError("uq: every modulus is fixed; at least one must have a distribution")

    @classmethod
    def default(cls, domain: Mapping[str, tuple[float, float]] | None = None, **counts) -> UQConfig:
        """Log-uniform over ``domain`` (default: the shipped calibration's); the rest fixed at
        :class:`isj.design.Materials`' defaults (the incus, 12 GPa)."""
        return cls(default_distributions(domain), **counts)

    @property
    def uncertain(self) -> tuple[str, ...]:
        """The moduli with a distribution (not fixed), in MODULI order."""
        return tuple(k for k in MODULI if self.distributions[k].uncertain)

    def to_dict(self) -> dict:
        return {
            "samples": self.samples,
            "sobol_samples": self.sobol_samples,
            "bootstrap": self.bootstrap,
            "seed": self.seed,
            "distributions": {k: self.distributions[k].to_dict() for k in MODULI},
        }


def default_distributions(domain: Mapping[str, tuple[float, float]] | None = None) -> dict[str, Distribution]:
    """Log-uniform over each modulus's [low, high] in ``domain`` (Pa; default: the shipped
    calibration's domain, docs/lumped.md §3.5); a pinned or missing modulus is fixed (its domain
    value, else :class:`isj.design.Materials`' default)."""
    if domain is None:
        from isj.lumped.artifact import default_calibration

        domain = default_calibration().domain
    m, out = Materials(), {}
    for k in MODULI:
        if k in domain and domain[k][1] > domain[k][0]:
            out[k] = Distribution.loguniform(float(domain[k][0]), float(domain[k][1]), k)
        else:
            out[k] = Distribution.fixed(float(domain[k][0]) if k in domain else getattr(m, k), k)
    return out


_CONFIG_KEYS = (
    "samples",
    "sobol_samples",
    "bootstrap",
    "seed",
    "transmission_samples",
    "transmission_sobol_samples",
)


def uq_config_from_dict(section: Mapping, domain=None, **overrides) -> UQConfig:
    """A :class:`UQConfig` from a ``[uq]`` table: counts and ``[uq.<modulus>]`` tables; moduli it
    does not name keep :func:`default_distributions`; ``overrides`` (not None) win over the table.

    Every value of the table is checked, also one that an override then replaces: an invalid
    file is refused whatever the command line says (:func:`check_count`).
    """
    if not isinstance(section, Mapping):
        raise ConfigError(f"uq = {section!r}: must be a [uq] table")
    dists = default_distributions(domain)
    counts = {}
    for key, value in section.items():
        if key in MODULI:
            dists[key] = Distribution.from_table(key, value)
        elif key == "transmission":
            if not isinstance(value, bool):
                raise ConfigError(f"uq.transmission = {value!r}: must be true or false")
            counts[key] = value
        elif key in _CONFIG_KEYS:
            counts[key] = check_count(key, value)
        else:
            raise ConfigError(
                f"uq.{key}: unknown key; valid: {', '.join((*_CONFIG_KEYS, 'transmission', *MODULI))}"
            )
    counts.update({k: v for k, v in overrides.items() if v is not None})
    return UQConfig(dists, **counts)


def check_count(key: str, value) -> int:
    """One count of a ``[uq]`` table (``samples``, ``sobol_samples``, ``bootstrap``, ``seed``) on its
    own: an integer (not a boolean) in its range, ``sobol_samples`` a power of 2; else a
    ConfigError naming ``uq.<key>`` and the range."""
    ranges = {
        "samples": SAMPLES_RANGE,
        "sobol_samples": SOBOL_SAMPLES_RANGE,
        "bootstrap": BOOTSTRAP_RANGE,
        "seed": SEED_RANGE,
        "transmission_samples": TRANSMISSION_SAMPLES_RANGE,
        "transmission_sobol_samples": TRANSMISSION_SOBOL_SAMPLES_RANGE,
    }
    v = _count(f"uq.{key}", value, *ranges[key])
    if key in ("sobol_samples", "transmission_sobol_samples") and v & (v - 1):
        example = 2**14 if key == "sobol_samples" else 2**10
        raise ConfigError(f"uq.{key} = {v}: must be a power of 2 (Sobol' balance), e.g. {example}")
    return v


def load_uq_config(path: str | Path, domain=None, **overrides) -> UQConfig:
    """The ``[uq]`` section of the TOML file at ``path`` (other sections are left to their owners)."""
    data = read_toml(path)
    if "uq" not in data:
        raise ConfigError(f"--config {str(path)!r}: has no [uq] section")
    return uq_config_from_dict(data["uq"], domain, **overrides)
