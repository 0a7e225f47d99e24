#!/usr/bin/env python3
"""Writes knob.obj: a closed, non-convex lathe mesh (a mushroom-shaped knob: a stem of radius
8 mm under a rounded cap of radius 20 mm, 30 mm tall overall; metres), the mesh the contact
scenarios' test renders (`hapticgen contact --mesh scenes/meshes/knob.obj`). Faces are
counter-clockwise seen from outside. Run it from this directory to regenerate the file."""
import math

SEGMENTS = 40
# The profile from the bottom pole to the top pole: (radius, height), m.
profile = [(0.0, 0.0), (0.008, 0.0), (0.008, 0.010), (0.010, 0.013), (0.016, 0.015)]
for k in range(1, 13):
    # The cap: a quarter ellipse from (0.020, 0.017) up to the top pole at 0.030.
    angle = 0.5 * math.pi * k / 12
    profile.append((0.020 * math.cos(angle), 0.017 + 0.013 * math.sin(angle)))
profile.insert(5, (0.020, 0.017))
profile[-1] = (0.0, 0.030)

vertices = [(0.0, 0.0, profile[0][1])]
rings = []
for radius, height in profile[1:-1]:
    ring = []
    for s in range(SEGMENTS):
        a = 2 * math.pi * s / SEGMENTS
        ring.append(len(vertices))
        vertices.append((radius * math.cos(a), radius * math.sin(a), height))
    rings.append(ring)
top = len(vertices)
vertices.append((0.0, 0.0, profile[-1][1]))

faces = []
for s in range(SEGMENTS):
    t = (s + 1) % SEGMENTS
    faces.append((0, rings[0][t], rings[0][s]))  # bottom, facing down
    for lower, upper in zip(rings, rings[1:]):
        faces.append((lower[s], lower[t], upper[t]))
        faces.append((lower[s], upper[t], upper[s]))
    faces.append((rings[-1][s], rings[-1][t], top))  # top, facing up

with open("knob.obj", "w") as out:
    out.write("# A mushroom-shaped knob, metres; written by make_knob.py.\n")
    for x, y, z in vertices:
        out.write(f"v {x:.9f} {y:.9f} {z:.9f}\n")
    for a, b, c in faces:
        out.write(f"f {a + 1} {b + 1} {c + 1}\n")
print(f"{len(vertices)} vertices, {len(faces)} faces")
