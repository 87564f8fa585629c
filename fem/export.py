"""Export to ParaView (VTU via meshio), written atomically.

P2 fields go out on VTK ``tetra10`` cells (the node order of ``fem.elements``),
so ParaView interpolates them quadratically. Point data: displacement (m);
cell data: region id and mean strain-energy density (J/m³). Use ParaView's
"Warp By Vector" on ``displacement_m`` to see the deformed model.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from isj.atomic import atomic_write, atomic_write_text


def write_vtu(path, space, displacement_m: np.ndarray, cell_data: dict[str, np.ndarray]) -> Path:
    """Write a mesh with a displacement field and per-cell data to ``path`` (.vtu)."""
    import meshio

    cell_type = "tetra" if space.order == 1 else "tetra10"
    mesh = meshio.Mesh(
        points=space.points,
        cells=[(cell_type, space.cells)],
        point_data={"displacement_m": np.asarray(displacement_m, dtype=float).reshape(-1, 3)},
        cell_data={k: [np.asarray(v)] for k, v in cell_data.items()},
    )
    return atomic_write(path, lambda tmp: meshio.write(tmp, mesh, file_format="vtu"))


def write_model_vtu(path, model, result) -> Path:
    """VTU of a solved ``PedicleJointModel``: displacement, region id, strain-energy density."""
    return write_vtu(
        path,
        model.space,
        result.displacement_m,
        {
            "region_id": model.space.region.astype(np.int32),
            "strain_energy_density_j_m3": model.strain_energy_density(result),
        },
    )


def write_pvd(path, files: list[str], times: list[float]) -> Path:
    """A ParaView collection (.pvd) indexing a sequence of VTU files (e.g. modes by frequency)."""
    rows = "\n".join(
        f'    <DataSet timestep="{t:.9g}" group="" part="0" file="{f}"/>'
        for f, t in zip(files, times, strict=True)
    )
    text = (
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        f"{rows}\n  </Collection>\n</VTKFile>\n"
    )
    return atomic_write_text(path, text)


def write_modes(directory, model, freq_hz, shapes) -> Path:
    """One VTU per mode (``mode_01.vtu``, ...) and ``modes.pvd`` with the frequency (Hz) as time."""
    directory = Path(directory)
    names = []
    for i in range(shapes.shape[1]):
        name = f"mode_{i + 1:02d}.vtu"
        write_vtu(
            directory / name, model.space, shapes[:, i], {"region_id": model.space.region.astype(np.int32)}
        )
        names.append(name)
    return write_pvd(directory / "modes.pvd", names, list(map(float, freq_hz)))
