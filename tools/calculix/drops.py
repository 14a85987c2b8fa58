#!/usr/bin/env python3
"""CalculiX (ccx 2.20) drop scenes: an independent source of depth observations.

For each case this writes a dynamic ccx deck of a deformable box (or a cylinder) dropped or thrown
onto one or two rigid planes, runs it, turns the body's surface at 60 Hz frames into
PLY meshes, and writes the matching ssc scene (scene.json) and cameras.  With
--render it then calls `ssc render` to make the observation folder.  Standard library
only; the body mesh is references.py's BoxMesh (20-node hexahedra).  Units: SI (m, kg,
s, N, Pa).  See tests/data/calculix_drops/README.md for the cases and settings.

    python3 tools/calculix/drops.py OUT [--cases a,b] [--frames N] [--elements N]
                                    [--ssc build/bin/ssc] [--jobs N]
"""

import argparse
import concurrent.futures
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import references  # noqa: E402  (BoxMesh, nset, read_dat, elastic, neo_hooke, run_ccx, ccx_version)

G = 9.81
FPS = 60
SLAB = 100000  # node and element ids of the planes start here

# --------------------------------------------------------------------------
# geometry


def rot_z(deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return ((c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0))


def mat_vec(R, v):
    return tuple(sum(R[i][k] * v[k] for k in range(3)) for i in range(3))


def add(a, b, s=1.0):
    return tuple(a[i] + s * b[i] for i in range(3))


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normal_from_angles(polar_deg, azimuth_deg):
    """ssc's convention (docs/scene-format.md): polar from +y, azimuth about +y from +x."""
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    return (math.sin(p) * math.cos(a), math.cos(p), math.sin(p) * math.sin(a))


def surface_triangles(mesh):
    """Boundary of a BoxMesh as triangles over its lattice nodes, outward oriented:
    each 8-node element face becomes 4 corner triangles and the mid-side quad (2)."""
    tris = []
    n = mesh.n
    for d in range(3):
        a, b = [e for e in range(3) if e != d]
        for side in (0, 1):
            for ia in range(n[a]):
                for ib in range(n[b]):
                    def node(sa, sb):
                        key = [0, 0, 0]
                        key[d] = 2 * n[d] * side
                        key[a] = 2 * ia + sa
                        key[b] = 2 * ib + sb
                        return mesh.id[tuple(key)]
                    c = [node(0, 0), node(2, 0), node(2, 2), node(0, 2)]
                    m = [node(1, 0), node(2, 1), node(1, 2), node(0, 1)]
                    face = [(m[3], c[0], m[0]), (m[0], c[1], m[1]), (m[1], c[2], m[2]),
                            (m[2], c[3], m[3]), (m[0], m[1], m[2]), (m[0], m[2], m[3])]
                    # (a, b, d) right-handed for d = 0, 2 (x: y,z; z: x,y), not for d = 1 (y: x,z)
                    outward = (side == 1) == (d != 1)
                    tris += [t if outward else (t[0], t[2], t[1]) for t in face]
    return tris


def write_ply(path, vertices, triangles):
    """Binary little-endian PLY, the layout models/io/ply_writer.h writes."""
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex %d\n"
            "property float x\nproperty float y\nproperty float z\n"
            "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
            % (len(vertices), len(triangles)))
    with open(path + ".tmp", "wb") as f:
        f.write(head.encode())
        for v in vertices:
            f.write(struct.pack("<3f", *v))
        for t in triangles:
            f.write(struct.pack("<B3i", 3, *t))
    os.replace(path + ".tmp", path)


# --------------------------------------------------------------------------
# cases

HALF = 0.1          # the body: a cube of 0.2 m
NU = 0.3
RHO = 500.0         # kg/m^3
CONTACT_K = 1e8     # N/m^3 (Pa per metre of overclosure), linear pressure-overclosure
SOFTMIN_ALPHA = 5e3  # 1/m, ssc's soft-min sharpness in the scenes (scene_json)
STICK_SLOPE = 1e6   # N/m^3, tangential stiffness of sticking friction (1e8 made ccx cut back to failure)
TILT = 20.0         # degrees, polar angle of the incline's normal (azimuth 0: it falls towards +x)

DOWNHILL = (math.cos(math.radians(TILT)), -math.sin(math.radians(TILT)), 0.0)  # the incline's slope line
SLIDE = tuple(1.2 * x for x in DOWNHILL)  # launched down the incline at 1.2 m/s

CASES = {
    # name: what, material (E), body half extents, planes [(polar, azimuth, height, friction)],
    # gap above the first plane, initial velocity and spin (rad/s, about the centre), duration
    "clean": dict(
        what="cube dropped flat onto a frictionless 20 degree incline and sliding down it",
        E=5e4, planes=[(TILT, 0.0, 0.0, None)], gap=0.04, velocity=(0.3, -1.5, 0.0), duration=0.35),
    "clean_gentle": dict(
        what="the clean drop set down gently, 2 cm above the incline at 0.5 m/s: at the 60 Hz frames the body is "
             "compressed by at most 4.9 % along the incline's normal, against the clean drop's 10 %, where CalculiX's "
             "Neo-Hookean body and a corotated one differ by more than the depth noise",
        E=5e4, planes=[(TILT, 0.0, 0.0, None)], gap=0.02, velocity=(0.3, -0.5, 0.0), duration=0.35),
    "clean_slide": dict(
        what="cube launched down a frictionless 20 degree incline at 1.2 m/s from 2 mm above it",
        E=5e4, planes=[(TILT, 0.0, 0.0, None)], gap=0.002, velocity=SLIDE, duration=0.35),
    "clean_brick": dict(
        what="a 0.3 x 0.1 x 0.2 m brick thrown spinning onto a flat frictionless floor: it lands on an edge",
        E=8e4, half=(0.15, 0.05, 0.1), planes=[(0.0, 0.0, 0.0, None)], gap=0.04, velocity=(0.8, -1.5, 0.0),
        spin=(0.0, 0.0, -3.0), duration=0.35),
    "two_materials": dict(
        what="the clean drop with a body of two materials, E = 50 kPa and 400 kPa, split across local x at the "
             "element boundary nearest the middle (halves with an even count of elements per edge; with 3, "
             "the soft third x < -h/3 and the stiff two thirds)",
        E=5e4, E_half=4e5, planes=[(TILT, 0.0, 0.0, None)], gap=0.04, velocity=(0.3, -1.5, 0.0),
        duration=0.35),
    "two_materials_gentle": dict(
        what="the gentle drop (clean_gentle) with the body of two_materials: one hidden effect, where the drop "
             "at 1.5 m/s also compresses the body to where its Neo-Hookean material shows",
        E=5e4, E_half=4e5, planes=[(TILT, 0.0, 0.0, None)], gap=0.02, velocity=(0.3, -0.5, 0.0),
        duration=0.35),
    "friction": dict(
        what="the clean slide with Coulomb friction mu = 0.5, started resting on the incline (pressed in by its "
             "static 0.01 mm: a drop of 2 mm made ccx cut back to failure; 0.2 s, as ccx's increments fall to 0.2 ms "
             "while it slides): it slows at g (sin a - mu cos a) = -1.25 m/s^2",
        E=5e4, planes=[(TILT, 0.0, 0.0, 0.5)], gap=-1e-5, velocity=SLIDE, duration=0.2, min_increment=1e-6),
    "second_plane": dict(
        what="cube thrown down a frictionless 20 degree ramp that ends in a wall (a second plane at x = 0.45 m)",
        E=5e4, planes=[(TILT, 0.0, 0.0, None), (90.0, 180.0, -0.45, None)], gap=0.04,
        velocity=(1.5, -1.0, 0.0), duration=0.5),
    "neo_hookean": dict(
        what="a soft Neo-Hookean cube (E = 10 kPa) thrown hard onto the incline: large strain (at 3 m/s, and at "
             "2 m/s with node-to-surface contact, ccx stopped at t = 0.095 and 0.147 s, its increment below the minimum)",
        E=1e4, neo_hookean=True, planes=[(TILT, 0.0, 0.0, None)], gap=0.04, velocity=(0.3, -2.0, 0.0),
        duration=0.35, min_increment=1e-6, contact="SURFACE TO SURFACE"),
    "floor_below": dict(
        what="cube thrown down a frictionless 20 degree incline onto the flat floor it ends on, 0.15 m below "
             "(a second plane below the body)",
        E=5e4, planes=[(TILT, 0.0, 0.0, None), (0.0, 0.0, -0.15, None)], gap=0.04, velocity=(1.2, -1.0, 0.0),
        duration=0.45),
    "cylinder_wall": dict(
        what="a cylinder (radius 0.1 m, 0.2 m long, lying on its side) thrown down a frictionless 30 degree "
             "incline into a wall facing -x at x = 0.5 m (surface-to-surface contact: with node-to-surface ccx cut "
             "back to failure at its landing)",
        E=5e4, shape="cylinder", planes=[(30.0, 0.0, 0.0, None), (90.0, 180.0, -0.5, None)], gap=0.04,
        velocity=(1.5, -1.0, 0.0), duration=0.45, contact="SURFACE TO SURFACE"),
    "cylinder": dict(
        what="a cylinder (radius 0.1 m, 0.2 m long, lying on its side, its axis across the slope) dropped onto a "
             "frictionless 30 degree incline and sliding down it: a third shape, clean (surface-to-surface contact, "
             "as cylinder_wall)",
        E=5e4, shape="cylinder", planes=[(30.0, 0.0, 0.0, None)], gap=0.04, velocity=(0.5, -1.0, 0.0),
        duration=0.35, contact="SURFACE TO SURFACE"),
    "friction_low": dict(
        what="the friction case with mu = 0.25, below tan 20 = 0.36: it speeds up at "
             "g (sin a - mu cos a) = 1.05 m/s^2 (a brick with friction made ccx cut back to failure at 10-25 ms, "
             "resting or dropped, node-to-surface or surface-to-surface contact)",
        E=5e4, planes=[(TILT, 0.0, 0.0, 0.25)], gap=-1e-5, velocity=SLIDE, duration=0.2, min_increment=1e-6),
}


def half_extents(case):
    return case.get("half", (HALF,) * 3)


def interface_x(case, elements):
    """Local x of the two-material body's interface: the element boundary nearest the middle
    on the soft side (0 for an even count of elements per edge, -h/3 for 3). The elements are
    split by their centroids there and the ssc scene's region starts there, so that both codes
    model the same body."""
    h = half_extents(case)[0]
    n = max(1, round(elements * h / HALF))
    return -h + (n // 2) * 2 * h / n


def node_velocity(case, centre, x):
    """The rigid start: v + w x (x - centre)."""
    return add(case["velocity"], cross(case.get("spin", (0.0, 0.0, 0.0)), add(x, centre, -1.0)))


def body_pose(case):
    """Rotation (about z, so that the cube's bottom face lies parallel to the first plane)
    and centre of the cube: gap metres above the first plane, above the world origin."""
    polar, azimuth, height, _ = case["planes"][0]
    assert azimuth == 0.0
    R = rot_z(-polar)
    n = normal_from_angles(polar, azimuth)
    centre = tuple((height + half_extents(case)[1] + case["gap"]) * n[i] for i in range(3))
    return R, centre


def slab_lines(k, polar, azimuth, height, first_node, first_elem):
    """A rigid plane: a 3 m x 1.6 m slab of 8-node bricks, 0.1 m thick, below the plane
    n . x = height, every node fixed.  Its top faces (S2) form the contact surface."""
    n = normal_from_angles(polar, azimuth)
    t1 = cross((0.0, 0.0, 1.0), n) if abs(n[2]) < 0.9 else cross((1.0, 0.0, 0.0), n)
    l1 = math.sqrt(dot(t1, t1))
    t1 = tuple(x / l1 for x in t1)
    t2 = cross(n, t1)  # (t1, t2, n) right-handed
    nu_, nw, su, sw, th = 12, 4, 1.5, 0.8, 0.1
    origin = tuple(height * x for x in n)
    ids = {}
    lines = ["*NODE, NSET=NPLANE%d" % k]
    nid = first_node
    for s in (0, 1):
        for j in range(nw + 1):
            for i in range(nu_ + 1):
                u = -su + 2 * su * i / nu_
                w = -sw + 2 * sw * j / nw
                p = add(add(add(origin, t1, u), t2, w), n, -th * (1 - s))
                ids[(i, j, s)] = nid
                lines.append("%d,%.10g,%.10g,%.10g" % (nid, *p))
                nid += 1
    lines.append("*ELEMENT, TYPE=C3D8, ELSET=EPLANE%d" % k)
    eid = first_elem
    faces = []
    for j in range(nw):
        for i in range(nu_):
            c = [ids[(i, j, 0)], ids[(i + 1, j, 0)], ids[(i + 1, j + 1, 0)], ids[(i, j + 1, 0)],
                 ids[(i, j, 1)], ids[(i + 1, j, 1)], ids[(i + 1, j + 1, 1)], ids[(i, j + 1, 1)]]
            lines.append("%d,%s" % (eid, ",".join(map(str, c))))
            faces.append(eid)
            eid += 1
    lines.append("*SURFACE, NAME=SPLANE%d, TYPE=ELEMENT" % k)
    lines += ["%d,S2" % e for e in faces]
    return lines, nid, eid


def deck_lines(name, case, mesh, mesh_file, surface_nodes, contact, dt_max):
    E = case["E"]
    R, centre = body_pose(case)
    lines = ["** %s: %s" % (name, case["what"]),
             "** written by tools/calculix/drops.py; units m, kg, s, N, Pa",
             "*INCLUDE, INPUT=%s" % mesh_file]
    lines += references.nset("NSURF", surface_nodes)
    node, elem = SLAB, SLAB
    for k, (polar, azimuth, height, _) in enumerate(case["planes"]):
        slab, node, elem = slab_lines(k, polar, azimuth, height, node, elem)
        lines += slab
    # materials: ccx's *ELASTIC under NLGEOM is St. Venant-Kirchhoff, which softens in compression
    # (at 15 % it is about 20 % softer than a corotated or Neo-Hookean body), so the body is
    # Neo-Hookean unless --material linear asks for the old decks
    body_material = references.neo_hooke if case["material"] == "neo_hookean" else references.elastic
    lines += body_material("BODY", E, NU, RHO)
    lines += references.elastic("RIGID", 1e9, 0.3, 1000.0)
    if "E_half" in case:
        lines += body_material("BODY2", case["E_half"], NU, RHO)
        lines += ["*SOLID SECTION, ELSET=SOFT, MATERIAL=BODY", "*SOLID SECTION, ELSET=STIFF, MATERIAL=BODY2"]
    else:
        lines += ["*SOLID SECTION, ELSET=EALL, MATERIAL=BODY"]
    for k in range(len(case["planes"])):
        lines += ["*SOLID SECTION, ELSET=EPLANE%d, MATERIAL=RIGID" % k]
    lines += ["*BOUNDARY"] + ["NPLANE%d, 1, 3, 0.0" % k for k in range(len(case["planes"]))]
    # body surface for contact: the element faces on the box boundary
    lines.append("*SURFACE, NAME=SBODY, TYPE=ELEMENT")
    for d in range(3):
        for side in (0, 1):
            lines += ["%d,S%d" % ef for ef in mesh.face_elements(d, side)]
    for k, plane in enumerate(case["planes"]):
        mu = plane[3]
        lines += ["*CONTACT PAIR, INTERACTION=SI%d, TYPE=%s" % (k, contact),
                  "SBODY, SPLANE%d" % k,
                  "*SURFACE INTERACTION, NAME=SI%d" % k,
                  "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
                  "%.6g" % CONTACT_K]
        if mu is not None:
            lines += ["*FRICTION", "%g, %.6g" % (mu, STICK_SLOPE)]
    lines += ["*INITIAL CONDITIONS, TYPE=VELOCITY"]
    if "spin" in case:
        for nid in sorted(mesh.coords):
            v = node_velocity(case, centre, mesh.coords[nid])
            lines += ["%d, %d, %.10g" % (nid, i + 1, v[i]) for i in range(3)]
    else:
        v = case["velocity"]  # world coordinates
        lines += ["NALL, %d, %.10g" % (i + 1, v[i]) for i in range(3)]
    frames = int(round(case["duration"] * FPS))
    lines += ["*TIME POINTS, NAME=FRAMES"] + ["%.10g" % (f / FPS) for f in range(1, frames + 1)]
    lines += ["*STEP, NLGEOM, INC=1000000",
              "*DYNAMIC, ALPHA=%g" % case["alpha"],
              "%.10g, %.10g, %.10g, %.10g" % (dt_max, case["duration"], case.get("min_increment", dt_max / 64), dt_max),
              "*DLOAD", "EALL, GRAV, %g, 0., -1., 0." % G,
              "*NODE PRINT, NSET=NSURF, TIME POINTS=FRAMES", "U",
              "*END STEP"]
    return lines


def body_mesh(case, elements):
    """The cube as a BoxMesh in its own frame, then placed: coordinates turned and moved
    into the world (the mesh's lattice bookkeeping stays in the local frame)."""
    R, centre = body_pose(case)
    h = half_extents(case)  # elements per edge: `elements` per 0.2 m
    mesh = references.BoxMesh(tuple(-x for x in h), h, tuple(max(1, round(elements * x / HALF)) for x in h))
    shape = cylinder_of_box if case.get("shape") == "cylinder" else (lambda p, h: p)
    mesh.coords = {k: add(centre, mat_vec(R, shape(p, h))) for k, p in mesh.coords.items()}
    return mesh


def cylinder_of_box(p, h):
    """The box's x-y cross-section mapped onto the disk of radius h[0] (the elliptical grid
    map u sqrt(1 - v^2 / 2), v sqrt(1 - u^2 / 2)): a cylinder along z."""
    u, v = p[0] / h[0], p[1] / h[1]
    return (h[0] * u * math.sqrt(1 - v * v / 2), h[0] * v * math.sqrt(1 - u * u / 2), p[2])


def run_case(name, case, out, elements, contact, dt_max):
    os.makedirs(out, exist_ok=True)
    mesh = body_mesh(case, elements)
    mesh_file = "mesh_%s.inp" % name
    split = interface_x(case, elements)
    elsets = [("SOFT", lambda c: c[0] < split), ("STIFF", lambda c: c[0] > split)]
    mesh.write(os.path.join(out, mesh_file), elsets)
    tris = surface_triangles(mesh)
    surface = sorted({v for t in tris for v in t})
    deck = "drop_%s" % name
    with open(os.path.join(out, deck + ".inp"), "w") as f:
        f.write("\n".join(deck_lines(name, case, mesh, mesh_file, surface, contact, dt_max)) + "\n")
    start, cpu = time.time(), os.times()
    blocks = references.run_ccx(out, deck)
    seconds = time.time() - start
    cpu_seconds = os.times().children_user - cpu.children_user + os.times().children_system - cpu.children_system
    frames = [b for b in blocks if b["kind"] == "displacements" and b["set"] == "NSURF"]
    expected = int(round(case["duration"] * FPS))
    if len(frames) != expected:
        raise RuntimeError("%s: ccx wrote %d frames, expected %d" % (deck, len(frames), expected))
    index = {nid: i for i, nid in enumerate(surface)}
    faces = [tuple(index[v] for v in t) for t in tris]
    ply_dir = os.path.join(out, "frames")
    if os.path.isdir(ply_dir):
        shutil.rmtree(ply_dir)
    os.makedirs(ply_dir)
    rest = [mesh.coords[nid] for nid in surface]
    write_ply(os.path.join(ply_dir, "frame_0000.ply"), rest, faces)
    times = [0.0]
    for f, b in enumerate(frames, start=1):
        if abs(b["time"] - f / FPS) > 1e-6:
            raise RuntimeError("%s: frame %d is at t = %g s, not %g s" % (deck, f, b["time"], f / FPS))
        times.append(b["time"])
        write_ply(os.path.join(ply_dir, "frame_%04d.ply" % f),
                  [add(mesh.coords[nid], b["rows"][nid]) for nid in surface], faces)
    return {"ccx_wall_seconds": round(seconds, 1), "ccx_cpu_seconds": round(cpu_seconds, 1), "frames": len(times), "surface_nodes": len(surface),
            "triangles": len(faces), "nodes": len(mesh.coords), "elements": len(mesh.elems)}


# --------------------------------------------------------------------------
# the ssc side: scene and cameras


def scene_json(name, case, cell_size, elements):
    """The same set-up as an ssc scene (docs/scene-format.md).  ssc's contact is a penalty
    with a soft minimum; its stiffness is ccx's and its soft-min sharpness is chosen so that
    the force builds up within 0.2 mm (alpha = 5e3 1/m), with the contact solved within the
    step (solver.contact = implicit).  ccx has no material damping, so neither has the scene;
    ccx's HHT integrator damps numerically with its ALPHA (gamma = 1/2 - alpha), and so does
    the scene's theta-scheme with theta = 1/2 - alpha (0.55 for ccx's default -0.05)."""
    R, centre = body_pose(case)
    polar = case["planes"][0][0]
    material = {"youngs_modulus": case["E"], "poisson_ratio": NU, "density": RHO,
                "mass_damping": 0.0, "stiffness_damping": 0.0}
    if case.get("neo_hookean"):
        material["model"] = "neo_hookean"
    if "E_half" in case:
        axis = mat_vec(R, (1.0, 0.0, 0.0))
        offset = dot(axis, centre) + interface_x(case, elements)
        material["regions"] = [{"normal": list(axis), "offset": offset, "youngs_modulus": case["E_half"]}]
    planes = []
    for k, (polar_k, azimuth_k, height_k, mu) in enumerate(case["planes"]):
        if k == 0 and case["gap"] < 0:  # a resting start: at ssc's contact equilibrium, where ccx's body rests
            height_k += case["gap"] - resting_distance(case)
        p = {"angles_deg": [polar_k, azimuth_k], "height": height_k}
        if mu is not None:
            p["friction"] = mu
        planes.append(p)
    dt = 1.0 / (10 * FPS)
    steps = int(round(case["duration"] / dt))
    return {
        "name": "calculix_%s" % name,
        "description": "CalculiX drop '%s': %s (tools/calculix/drops.py)" % (name, case["what"]),
        "object": {"mesh": "frames/frame_0000.ply"} if case.get("shape") == "cylinder" else
                  {"primitive": "box", "half_extents": list(half_extents(case)), "position": list(centre),
                   "rotation_deg": [0, 0, -polar]},
        "grid": {"cell_size": cell_size},
        "material": material,
        "gravity": [0, -G, 0],
        "initial": {"linear_velocity": list(case["velocity"]),
                    "angular_velocity": list(case.get("spin", (0.0, 0.0, 0.0)))},
        "ground": {"planes": planes, "stiffness": CONTACT_K, "softmin_alpha": SOFTMIN_ALPHA},
        "time": {"dt": dt, "steps": steps, "theta": 0.5 - case["alpha"]},
        "solver": {"contact": "implicit"},
        "observation": {"every": 10, "depth_scale": 1e-4, "cameras": cameras(case)},
    }


def resting_distance(case):
    """How far above the first plane ssc's soft-min contact holds the body at rest: its push
    k softplus(-alpha d) / alpha per unit area equals the body's pressure rho g h cos(polar).
    (ccx's linear contact holds it 0.01 mm inside; started there, ssc's body is thrown up by
    2.9 mm, and its friction brakes it meanwhile: docs/diagnosis.md.)"""
    pressure = RHO * G * math.cos(math.radians(case["planes"][0][0])) * 2 * half_extents(case)[1]
    alpha = SOFTMIN_ALPHA
    return -math.log(math.expm1(pressure * alpha / CONTACT_K)) / alpha


def cameras(case):
    """Two depth cameras, 160 x 120 pixels, looking at where the body slides: one from the
    front (+z), one from above and to the side."""
    target = [0.35, 0.0, 0.0]
    return [
        {"name": "front", "width": 160, "height": 120, "eye": [0.35, 0.35, 1.6], "target": target,
         "fov_deg": 45, "min_depth": 0.3, "max_depth": 4.0},
        {"name": "above", "width": 160, "height": 120, "eye": [-0.6, 1.3, 0.9], "target": target,
         "fov_deg": 45, "min_depth": 0.3, "max_depth": 4.0},
    ]


def write_json(path, doc):
    with open(path + ".tmp", "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    os.replace(path + ".tmp", path)


def make_case(name, a):
    """Runs one case into OUT/name: ccx, PLY frames, scene.json, ccx_run.json, and obs/ with --ssc."""
    case = dict(CASES[name])
    case["material"] = "neo_hookean" if case.get("neo_hookean") else a.material
    case["alpha"] = a.alpha
    if a.duration:
        case["duration"] = a.duration
    out = os.path.join(a.out, name)
    info = run_case(name, case, out, a.elements, case.get("contact", a.contact), a.dt)
    scene = scene_json(name, case, a.cell_size, a.elements)
    scene["time"]["steps"] = (info["frames"] - 1) * 10
    write_json(os.path.join(out, "scene.json"), scene)
    info.update({"what": case["what"], "ccx_version": references.ccx_version(), "element": references.ELEMENT,
                 "elements_per_edge": a.elements, "ccx_max_increment_s": a.dt, "contact": case.get("contact", a.contact),
                 "contact_stiffness_N_per_m3": CONTACT_K, "fps": FPS, "ccx_alpha": case["alpha"],
                 "ccx_material": case["material"]})
    write_json(os.path.join(out, "ccx_run.json"), info)
    for f in os.listdir(out):  # keep the deck, the mesh, the .dat and the log
        if f.split(".")[-1] in ("frd", "12d", "cvg", "sta") or f == "spooles.out":
            os.remove(os.path.join(out, f))
    if a.ssc:
        subprocess.run([a.ssc, "render", os.path.join(out, "frames"), "--cameras", os.path.join(out, "scene.json"),
                        "--fps", str(FPS), "--out", os.path.join(out, "obs"), "--quiet"], check=True)
    print("%s: %d frames, ccx %.1f s cpu (%.1f s wall), %d nodes" % (
        name, info["frames"], info["ccx_cpu_seconds"], info["ccx_wall_seconds"], info["nodes"]), flush=True)
    return info


def main():
    global CONTACT_K
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", help="output folder, one sub-folder per case")
    ap.add_argument("--cases", default=",".join(CASES), help="comma-separated, of: " + ", ".join(CASES))
    # 6: with 3, ccx's own answer was off by more than the depth noise (the spinning brick's
    # bounce 13 mm higher than with 6, the clean cube's path up to 9 mm apart;
    # docs/diagnosis.md, "CalculiX's own mesh")
    ap.add_argument("--elements", type=int, default=6, help="C3D20R elements along each 0.2 m edge (default 6)")
    ap.add_argument("--duration", type=float, default=None, help="seconds simulated (default: each case's)")
    ap.add_argument("--dt", type=float, default=1.0 / 600, help="largest ccx time increment, s")
    ap.add_argument("--cell-size", type=float, default=0.025, help="ssc grid cell size of the scene, m")
    ap.add_argument("--contact", default="NODE TO SURFACE", help="ccx contact type (a case may name its own)")
    ap.add_argument("--contact-stiffness", type=float, default=CONTACT_K,
                    help="ccx's linear pressure-overclosure slope and ssc's ground.stiffness, N/m^3 (default %g)" % CONTACT_K)
    ap.add_argument("--material", choices=("neo_hookean", "linear"), default="neo_hookean",
                    help="the body's ccx material: Neo-Hookean (default), or linear elastic, which under NLGEOM "
                         "is St. Venant-Kirchhoff (the neo_hookean case is always Neo-Hookean)")
    ap.add_argument("--alpha", type=float, default=-0.05,
                    help="ccx's *DYNAMIC ALPHA, its numerical damping (-1/3 .. 0; ccx's default -0.05)")
    ap.add_argument("--ssc", default=None, help="ssc binary: render the frames into OUT/CASE/obs")
    ap.add_argument("--jobs", type=int, default=os.cpu_count(), help="cases run at once (one ccx each)")
    a = ap.parse_args()
    CONTACT_K = a.contact_stiffness
    names = a.cases.split(",")
    for name in names:
        if name not in CASES:
            sys.exit("drops.py: unknown case '%s'; the cases are %s" % (name, ", ".join(CASES)))
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, a.jobs)) as pool:
        infos = dict(zip(names, pool.map(lambda n: make_case(n, a), names)))
    write_json(os.path.join(a.out, "runs.json"), infos)


if __name__ == "__main__":
    main()
