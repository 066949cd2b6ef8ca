#!/usr/bin/env python3
"""Writes the small-triangle speed scene: a 3x3 wall of icospheres of 20,480 triangles each
(184,320 in all, about ten covered pixels per front-facing triangle at 1280x1440 per eye in the
llvmpipe kit's view) on a ground quad, as one GLB.
None of the real scenes in ../shared/scenes is a dense mesh; issue 13's targets name one
(~200K triangles) beside a game level. Deterministic: the same bytes on every run.

usage: dense-mesh.py OUT.glb   (needs PyPI's trimesh and numpy)
"""
import sys

import numpy as np
import trimesh

if len(sys.argv) != 2:
    sys.exit("usage: dense-mesh.py OUT.glb")
parts = []
for row in range(3):
    for column in range(3):
        sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.5)
        sphere.apply_translation([1.05 * (column - 1), 0.55 + 1.05 * row, 0.0])
        parts.append(sphere)
ground = trimesh.Trimesh(
    vertices=np.array([[-2.0, 0.0, -1.5], [2.0, 0.0, -1.5], [2.0, 0.0, 1.5], [-2.0, 0.0, 1.5]]),
    faces=np.array([[0, 2, 1], [0, 3, 2]]),
    process=False,
)
parts.append(ground)
mesh = trimesh.util.concatenate(parts)
mesh.export(sys.argv[1], file_type="glb")
print(f"{sys.argv[1]}: {len(mesh.faces)} triangles")
