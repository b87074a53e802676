"""xatlas's UV atlas, run in a child process (``python .../barkgen/tree/_unwrap.py``).

xatlas holds the interpreter for its whole call (the built-in tree: 2.5 s), so in the run's own
process Ctrl-C would wait for it; :func:`barkgen.tree.mesh.unwrap` runs it here instead and
stops the child at once. Reads an ``.npz`` of ``vertices``, ``faces`` and ``resolution`` on
stdin and writes one of ``vertex_map``, ``faces`` and ``uv`` on stdout.
"""

from __future__ import annotations

import io
import sys

import numpy as np


def atlas(vertices: np.ndarray, faces: np.ndarray, resolution: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(vertex_map, faces, uv)`` of xatlas's atlas of the mesh, charts packed with a gutter of
    a few texels at ``resolution`` (see :func:`barkgen.tree.mesh.unwrap`)."""
    import xatlas

    atlas = xatlas.Atlas()
    atlas.add_mesh(np.ascontiguousarray(vertices, np.float32), np.ascontiguousarray(faces, np.uint32))
    charts = xatlas.ChartOptions()
    charts.max_iterations = 1
    charts.normal_deviation_weight = 0.5  # bark charts may curve round a branch: fewer, larger charts
    charts.normal_seam_weight = 0.0
    pack = xatlas.PackOptions()
    pack.resolution = int(resolution)
    pack.padding = max(4, int(resolution) // 256)
    pack.bilinear = True
    atlas.generate(chart_options=charts, pack_options=pack)
    return atlas[0]


def main() -> None:
    """The child's side: the mesh from stdin, the atlas to stdout."""
    given = np.load(io.BytesIO(sys.stdin.buffer.read()))
    vertex_map, faces, uv = atlas(given["vertices"], given["faces"], int(given["resolution"]))
    out = io.BytesIO()
    np.savez(out, vertex_map=vertex_map, faces=faces, uv=uv)
    sys.stdout.buffer.write(out.getvalue())


if __name__ == "__main__":
    main()
