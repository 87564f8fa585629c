"""Bode plots of a frequency response: computation elsewhere, drawing here.

``bode(freq_hz, response, ...)`` draws on given axes (or new ones) and returns
the artists, in the style of python-control's ``freqplot``: Hz on a log axis,
magnitude on a log axis in physical units, phase unwrapped in degrees below.
"""

from __future__ import annotations

import numpy as np

LABELS = {"alpha_rad": ("α (joint)", "rad"), "beta_rad": ("β (pedicle)", "rad")}


def bode(freq_hz, response, checks=(), outputs=("alpha_rad", "beta_rad"), axes=None):
    """Magnitude and unwrapped phase of ``response[:, j]`` for each output j, FE checks as markers.

    Parameters
    ----------
    freq_hz : (n,) frequencies (Hz)
    response : (n, n_out) complex amplitudes, columns in the order of ``outputs``
    checks : dicts with ``freq_hz`` and ``fe_<output>`` = [re, im] (FE spot checks)
    axes : (magnitude axis, phase axis) or None for a new ``matplotlib.figure.Figure``

    Returns
    -------
    list of matplotlib artists
    """
    if axes is None:  # a bare Figure: no pyplot, so the caller's backend and figure list stay untouched
        from matplotlib.figure import Figure

        axes = Figure(figsize=(7, 6)).subplots(2, 1, sharex=True)
    ax_mag, ax_ph = axes
    artists = []
    for j, key in enumerate(outputs):
        label, unit = LABELS.get(key, (key, ""))
        h = response[:, j]
        (line,) = ax_mag.loglog(freq_hz, np.abs(h), label=f"{label}, lumped")
        artists.append(line)
        artists += ax_ph.semilogx(freq_hz, np.degrees(np.unwrap(np.angle(h))), color=line.get_color())
        pts = [(c["freq_hz"], complex(*c[f"fe_{key}"])) for c in checks if f"fe_{key}" in c]
        if pts:
            f, v = zip(*pts, strict=True)
            v = np.array(v)
            artists.append(
                ax_mag.plot(
                    f, np.abs(v), "o", color=line.get_color(), mfc="none", label=f"{label}, FE check"
                )[0]
            )
            # FE phase placed on the lumped curve's branch of the unwrapped phase
            ref = np.interp(f, freq_hz, np.unwrap(np.angle(h)))
            ph = np.angle(v) + 2 * np.pi * np.round((ref - np.angle(v)) / (2 * np.pi))
            artists.append(ax_ph.plot(f, np.degrees(ph), "o", color=line.get_color(), mfc="none")[0])
    ax_mag.set_ylabel("magnitude (rad)")
    ax_ph.set_ylabel("phase (deg)")
    ax_ph.set_xlabel("frequency (Hz)")
    ax_mag.legend(fontsize=8)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    return artists


def save_bode(path, freq_hz, response, checks=()) -> None:
    """Draw :func:`bode` on a new figure and write it atomically (format from the suffix)."""
    from matplotlib.figure import Figure

    from isj.atomic import atomic_write

    # Figure.savefig picks a canvas for the file format itself: no backend is selected
    fig = Figure(figsize=(7, 6))
    axes = fig.subplots(2, 1, sharex=True)
    bode(freq_hz, response, checks, axes=axes)
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, format=str(path).rsplit(".", 1)[-1]))
