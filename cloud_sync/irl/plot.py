"""The figure of a learned table: the recovered (v, g) reward as a heatmap (normalised per
speed), the DGPT on it, the empirical baseline dashed and speeds without evidence shaded; drawn
on a bare :class:`matplotlib.figure.Figure` (no pyplot), imported only for ``--plot``.
"""

from __future__ import annotations

import os

import matplotlib as mpl
import numpy as np
from matplotlib.figure import Figure

from cloud_sync.irl.trainer import LearnResult


def plot_result(result: LearnResult, path: str | os.PathLike[str]) -> None:
    """Write the figure of ``result`` to ``path`` (format from the suffix, e.g. ``.png``)."""
    table = result.table
    v = table.speed_mps
    g_top = float(max(np.max(table.gap_m), np.max(result.mdp.grid.gap_m))) * 1.05
    g = np.linspace(0.0, g_top, 300)
    r = result.reward_vg(v, g)
    lo = r.min(axis=1, keepdims=True)
    span = np.maximum(r.max(axis=1, keepdims=True) - lo, 1e-12)
    r_norm = (r - lo) / span
    r_norm[~result.covered] = np.nan  # no evidence: the reward there means nothing
    cmap = mpl.colormaps["viridis"].with_extremes(bad="lightgrey")
    fig = Figure(figsize=(8, 5), dpi=110)
    ax = fig.subplots()
    mesh = ax.pcolormesh(v, g, np.ma.masked_invalid(r_norm.T), shading="auto", cmap=cmap)
    fig.colorbar(mesh, ax=ax, label="recovered reward r(v, g), normalised per speed")
    ax.plot(v, table.gap_m, color="red", lw=2.2, label=f"DGPT (IRL, v{table.version})")
    if result.baseline is not None:
        ax.plot(
            v,
            result.baseline.gap_m,
            "--",
            color="orange",
            lw=1.5,
            label="empirical steady-state baseline",
        )
    ax.fill_between([], [], color="lightgrey", label="no evidence: time-gap continuation")
    ax.set_xlabel("ego speed v (m/s)")
    ax.set_ylabel("gap g (m)")
    ax.set_ylim(0, g_top)
    ax.set_title(f"driver {table.driver_id} ({table.condition}): reward and desired gap")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
