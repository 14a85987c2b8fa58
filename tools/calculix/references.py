#!/usr/bin/env python3
"""CalculiX (ccx) reference results for ssc's static FEM tests.

Writes the input decks (structured meshes of 20-node hexahedra), runs ccx on
each, reads the nodal results from the .dat files and writes one small JSON
file per case into the output folder (tests/data/calculix/).  Standard library
only.  Called by tools/calculix/make-references.sh; see
tests/data/calculix/README.md for what the cases are.

Units: SI (m, kg, s, N, Pa).
"""

import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile

G = 9.81
ELEMENT = "C3D20R"

# --------------------------------------------------------------------------
# structured 20-node hexahedral mesh of a box


class BoxMesh:
    """Box [x0,x1]x[y0,y1]x[z0,z1] cut into nx*ny*nz C3D20(R) elements.

    Nodes live on a doubled lattice (2nx+1)x(2ny+1)x(2nz+1); a lattice point is
    a node unless two or more of its indices are odd (face / body centres of
    the 27-node brick, which the 20-node brick lacks).
    """

    def __init__(self, lo, hi, n):
        self.lo, self.hi, self.n = lo, hi, n
        nx, ny, nz = n
        self.id = {}
        self.coords = {}
        nid = 0
        for k in range(2 * nz + 1):
            for j in range(2 * ny + 1):
                for i in range(2 * nx + 1):
                    if (i % 2) + (j % 2) + (k % 2) >= 2:
                        continue
                    nid += 1
                    self.id[(i, j, k)] = nid
                    self.coords[nid] = tuple(
                        lo[d] + (hi[d] - lo[d]) * idx / (2 * n[d])
                        for d, idx in enumerate((i, j, k)))
        # element connectivity in ccx order (manual, Fig. "20-node brick")
        loc = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
               (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1),
               (0, -1, -1), (1, 0, -1), (0, 1, -1), (-1, 0, -1),
               (0, -1, 1), (1, 0, 1), (0, 1, 1), (-1, 0, 1),
               (-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
        self.elems = {}
        self.centroid = {}
        eid = 0
        for k in range(nz):
            for j in range(ny):
                for i in range(nx):
                    eid += 1
                    c = (2 * i + 1, 2 * j + 1, 2 * k + 1)
                    self.elems[eid] = [self.id[(c[0] + a, c[1] + b, c[2] + d)]
                                       for a, b, d in loc]
                    self.centroid[eid] = tuple(
                        lo[dd] + (hi[dd] - lo[dd]) * (c[dd]) / (2 * n[dd])
                        for dd in range(3))

    def lattice(self, d, idx):
        return [v for key, v in self.id.items() if key[d] == idx]

    def plane_index(self, d, value):
        """Lattice index of the plane coordinate d == value (must exist)."""
        t = (value - self.lo[d]) / (self.hi[d] - self.lo[d]) * 2 * self.n[d]
        idx = int(round(t))
        if abs(t - idx) > 1e-9:
            raise ValueError("no node plane at %g" % value)
        return idx

    def node_at(self, p):
        key = tuple(self.plane_index(d, p[d]) for d in range(3))
        return self.id[key]

    def plane_nodes(self, d, value):
        return sorted(self.lattice(d, self.plane_index(d, value)))

    def plane_weights(self, d, value):
        """Area weights {node: w}, sum w = 1, such that sum w*u is the exact
        area mean of the quadratic (8-node serendipity) interpolant of u over
        the plane d == value: per rectangular face, corner nodes -A/12,
        mid-side nodes +A/3."""
        idx = self.plane_index(d, value)
        a, b = [e for e in range(3) if e != d]
        w = {}
        for ja in range(self.n[a]):
            for jb in range(self.n[b]):
                for sa in (0, 1, 2):
                    for sb in (0, 1, 2):
                        if sa == 1 and sb == 1:
                            continue
                        key = [0, 0, 0]
                        key[d] = idx
                        key[a] = 2 * ja + sa
                        key[b] = 2 * jb + sb
                        node = self.id[tuple(key)]
                        wt = 1.0 / 3 if (sa == 1 or sb == 1) else -1.0 / 12
                        w[node] = w.get(node, 0.0) + wt / (self.n[a] * self.n[b])
        return w

    def face_elements(self, d, side):
        """(element, ccx face number) pairs on the box face d = lo (side 0)
        or hi (side 1)."""
        face = {(0, 0): 6, (0, 1): 4, (1, 0): 3, (1, 1): 5, (2, 0): 1, (2, 1): 2}[(d, side)]
        out = []
        for eid in self.elems:
            c = self.centroid[eid]
            h = (self.hi[d] - self.lo[d]) / self.n[d]
            edge = self.lo[d] + h / 2 if side == 0 else self.hi[d] - h / 2
            if abs(c[d] - edge) < 1e-9:
                out.append((eid, face))
        return out

    def write(self, path, elsets):
        """Mesh include file: *NODE, *ELEMENT, ELSET=EALL, named ELSETs."""
        lines = ["** structured %s mesh %dx%dx%d of [%g,%g]x[%g,%g]x[%g,%g] (m)"
                 % (ELEMENT, *self.n, self.lo[0], self.hi[0], self.lo[1],
                    self.hi[1], self.lo[2], self.hi[2]),
                 "*NODE, NSET=NALL"]
        for nid in sorted(self.coords):
            x, y, z = self.coords[nid]
            lines.append("%d,%.10g,%.10g,%.10g" % (nid, x, y, z))
        lines.append("*ELEMENT, TYPE=%s, ELSET=EALL" % ELEMENT)
        for eid in sorted(self.elems):
            c = self.elems[eid]
            lines.append("%d,%s," % (eid, ",".join(map(str, c[:15]))))
            lines.append(",".join(map(str, c[15:])))
        for name, pred in elsets:
            ids = [e for e in sorted(self.elems) if pred(self.centroid[e])]
            lines.append("*ELSET, ELSET=%s" % name)
            lines += [",".join(map(str, ids[i:i + 16])) + ","
                      for i in range(0, len(ids), 16)]
        with open(path, "w") as f:
            f.write("\n".join(lines) + "\n")


def nset(name, nodes):
    out = ["*NSET, NSET=%s" % name]
    nodes = sorted(nodes)
    out += [",".join(map(str, nodes[i:i + 16])) + "," for i in range(0, len(nodes), 16)]
    return out


# --------------------------------------------------------------------------
# .dat reader


def read_dat(path):
    """Returns a list of blocks {kind, set, time, rows}; rows maps node -> [v]
    (for 'total' blocks rows is [fx, fy, fz])."""
    blocks = []
    cur = None
    head = re.compile(r"^\s*(displacements|forces|total force)\s*\([^)]*\)\s*for set\s+(\S+)\s+and time\s+(\S+)")
    with open(path) as f:
        for line in f:
            m = head.match(line)
            if m:
                cur = {"kind": m.group(1), "set": m.group(2),
                       "time": float(m.group(3)), "rows": {}}
                blocks.append(cur)
                continue
            parts = line.split()
            if cur is None or not parts:
                continue
            try:
                vals = [float(p) for p in parts]
            except ValueError:
                cur = None
                continue
            if cur["kind"] == "total force":
                cur["rows"] = vals
            else:
                cur["rows"][int(vals[0])] = vals[1:]
    return blocks


def block(blocks, kind, setname, time=None):
    cand = [b for b in blocks if b["kind"] == kind and b["set"] == setname.upper()]
    if time is None:
        return cand[-1]
    best = min(cand, key=lambda b: abs(b["time"] - time))
    if abs(best["time"] - time) > 1e-6:
        raise RuntimeError("no output at time %g in %s" % (time, setname))
    return best


# --------------------------------------------------------------------------
# analytic comparisons


def beam_deflection(a, L, q, EI_of_x, GA_k_of_x=None, n=20000):
    """Cantilever clamped at x=0, uniform load q (downward positive), at
    station a: Euler-Bernoulli deflection by the unit-load integral
    w(a) = int_0^a M(x)(a-x)/EI(x) dx with M = q (L-x)^2/2, plus (optional)
    the Timoshenko shear part int_0^a V(x)/(k G A)(x) dx, V = q (L-x)."""
    h = a / n
    wb = ws = 0.0
    for i in range(n):
        x = (i + 0.5) * h
        wb += q * (L - x) ** 2 / 2 * (a - x) / EI_of_x(x) * h
        if GA_k_of_x:
            ws += q * (L - x) / GA_k_of_x(x) * h
    return wb, ws


def elastica(q, L, EI, n=4000):
    # EI: a number or a function of the arc length s
    """Inextensible, shear-rigid Euler-Bernoulli rod (elastica), clamped at
    s = 0 (horizontal), free at s = L, own weight q per unit length along -y.
    theta' = -M/EI, M' = -q (L - s) cos(theta), theta(0) = 0, M(L) = 0;
    shooting on M(0) by bisection, RK4.  Returns the tip displacement
    (ux, uy) of the centre line and the root bending moment M(0)."""
    h = L / n
    EIf = EI if callable(EI) else (lambda s: EI)

    def shoot(M0):
        th, M, x, y = 0.0, M0, 0.0, 0.0
        f = lambda s, th, M: (-M / EIf(s), -q * (L - s) * math.cos(th))
        for i in range(n):
            s = i * h
            k1 = f(s, th, M)
            k2 = f(s + h / 2, th + h / 2 * k1[0], M + h / 2 * k1[1])
            k3 = f(s + h / 2, th + h / 2 * k2[0], M + h / 2 * k2[1])
            k4 = f(s + h, th + h * k3[0], M + h * k3[1])
            thm = th + h / 4 * (k1[0] + k2[0])
            thn = th + h * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]) / 6
            x += h / 6 * (math.cos(th) + 4 * math.cos(thm) + math.cos(thn))
            y += h / 6 * (math.sin(th) + 4 * math.sin(thm) + math.sin(thn))
            M += h * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]) / 6
            th = thn
        return M, x, y
    lo, hi = 0.0, q * L * L / 2
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if shoot(mid)[0] > 0:
            hi = mid
        else:
            lo = mid
    M0 = 0.5 * (lo + hi)
    _, x, y = shoot(M0)
    return x - L, y, M0


def neo_hooke_uniaxial(lam, C10, D1):
    """ccx NEO HOOKE, U = C10 (I1bar-3) + (J-1)^2/D1, homogeneous uniaxial
    stress (lateral faces traction free).  Returns (lateral stretch,
    nominal stress P = force / reference area)."""
    def tau(l1, l2, l3):
        J = l1 * l2 * l3
        I1 = l1 * l1 + l2 * l2 + l3 * l3
        iso = lambda li: C10 * J ** (-2.0 / 3) * (2 * li * li - 2.0 / 3 * I1)
        vol = 2.0 / D1 * (J - 1) * J
        return iso(l1) + vol, iso(l2) + vol
    lo, hi = 0.2, 3.0  # bisection on the lateral stretch: tau_22 = 0
    flo = tau(lam, lo, lo)[1]
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        fm = tau(lam, mid, mid)[1]
        if (fm > 0) == (flo > 0):
            lo, flo = mid, fm
        else:
            hi = mid
    lt = 0.5 * (lo + hi)
    return lt, tau(lam, lt, lt)[0] / lam


# --------------------------------------------------------------------------
# cases

BAR_GRAV = ((0.0, 0.45, -0.05), (1.0, 0.55, 0.05))
BAR_TENS = ((0.0, -0.05, -0.05), (1.0, 0.05, 0.05))
BLOCK = ((0.0, 0.0, 0.0), (0.1, 0.1, 0.1))

DENSITIES = {  # name -> elements (nx, ny, nz)
    "bar": {"coarse": (20, 2, 2), "fine": (40, 4, 4)},
    "tension": {"coarse": (10, 2, 2), "fine": (20, 4, 4)},
    "block": {"coarse": (2, 2, 2), "fine": (4, 4, 4)},
}
# convergence check of the linear cantilevers only: its mesh (about 1 MB) is
# written to the scratch folder and not kept
CHECK_BAR = (80, 8, 8)


def elastic(name, E, nu, rho=None):
    out = ["*MATERIAL, NAME=%s" % name, "*ELASTIC", "%.10g, %.10g" % (E, nu)]
    if rho is not None:
        out += ["*DENSITY", "%.10g" % rho]
    return out


def neo_hooke(name, E, nu, rho=None):
    mu = E / (2 * (1 + nu))
    K = E / (3 * (1 - 2 * nu))
    out = ["*MATERIAL, NAME=%s" % name, "*HYPERELASTIC, NEO HOOKE",
           "%.10g, %.10g" % (mu / 2, 2 / K)]
    if rho is not None:
        out += ["*DENSITY", "%.10g" % rho]
    return out


class Deck:
    def __init__(self, name, mesh_file, mesh, lines, post):
        self.name, self.mesh_file, self.mesh = name, mesh_file, mesh
        self.lines, self.post = lines, post


def cantilever_deck(name, mesh_file, mesh, E_left, E_right, nonlinear=False):
    lines = ["** %s: cantilever under its own weight, g = %g m/s^2 along -y" % (name, G),
             "*INCLUDE, INPUT=%s" % mesh_file]
    lines += nset("FIX", mesh.plane_nodes(0, 0.0))
    lines += nset("TIP", [mesh.node_at((1.0, 0.5, 0.0))])
    lines += nset("XEND", mesh.plane_nodes(0, 1.0))
    lines += nset("LINE", [mesh.node_at((x, 0.5, 0.0)) for x in (0.25, 0.5, 0.75, 1.0)])
    mat = neo_hooke if nonlinear else elastic
    if E_left == E_right:
        lines += mat("M1", E_left, 0.3, 100.0)
        lines += ["*SOLID SECTION, ELSET=EALL, MATERIAL=M1"]
    else:
        lines += mat("M1", E_left, 0.3, 100.0) + mat("M2", E_right, 0.3, 100.0)
        lines += ["*SOLID SECTION, ELSET=LEFT, MATERIAL=M1",
                  "*SOLID SECTION, ELSET=RIGHT, MATERIAL=M2"]
    lines += ["*BOUNDARY", "FIX, 1, 3, 0.0"]
    if nonlinear:
        lines += ["*STEP, NLGEOM, INC=1000", "*STATIC", "0.05, 1.0, 1e-5, 0.1"]
    else:
        lines += ["*STEP", "*STATIC"]
    lines += ["*DLOAD", "EALL, GRAV, %g, 0., -1., 0." % G,
              "*NODE PRINT, NSET=XEND, FREQUENCY=1000", "U",
              "*NODE PRINT, NSET=LINE, FREQUENCY=1000", "U",
              "*NODE PRINT, NSET=FIX, TOTALS=ONLY, FREQUENCY=1000", "RF",
              "*END STEP"]
    return lines


def tension_deck(name, mesh_file, mesh):
    traction = 1000.0
    lines = ["** %s: bar in tension, traction %g Pa on x = 1, E = 1e6 (x<0.5) / 4e6 (x>0.5)"
             % (name, traction),
             "*INCLUDE, INPUT=%s" % mesh_file]
    lines += nset("X0", mesh.plane_nodes(0, 0.0))
    lines += nset("XMID", mesh.plane_nodes(0, 0.5))
    lines += nset("XEND", mesh.plane_nodes(0, 1.0))
    lines += nset("PIN", [mesh.node_at((0.0, 0.0, 0.0))])
    lines += nset("PIN2", [mesh.node_at((0.0, 0.0, 0.05))])
    lines += elastic("M1", 1e6, 0.3) + elastic("M2", 4e6, 0.3)
    lines += ["*SOLID SECTION, ELSET=LEFT, MATERIAL=M1",
              "*SOLID SECTION, ELSET=RIGHT, MATERIAL=M2",
              "** x = 0 face: u_x = 0; centre node also u_y = u_z = 0; node (0,0,0.05) u_y = 0",
              "*BOUNDARY", "X0, 1, 1, 0.0", "PIN, 2, 3, 0.0", "PIN2, 2, 2, 0.0",
              "*STEP", "*STATIC",
              "** face 4 of the brick (nodes 2-6-7-3) is its +x face; negative pressure = tension",
              "*DLOAD"]
    lines += ["%d, P%d, %g" % (e, f, -traction) for e, f in mesh.face_elements(0, 1)]
    lines += ["*NODE PRINT, NSET=XEND", "U",
              "*NODE PRINT, NSET=XMID", "U",
              "*NODE PRINT, NSET=X0, TOTALS=ONLY", "RF",
              "*END STEP"]
    return lines


def block_deck(name, mesh_file, mesh, stretch, ninc):
    E, nu, a = 1e4, 0.3, 0.1
    lines = ["** %s: Neo-Hooke cube (E = %g Pa, nu = %g small-strain), top face moved to stretch %g"
             % (name, E, nu, stretch),
             "*INCLUDE, INPUT=%s" % mesh_file]
    lines += nset("BOT", mesh.plane_nodes(1, 0.0))
    lines += nset("TOP", mesh.plane_nodes(1, a))
    lines += nset("MIDH", mesh.plane_nodes(1, a / 2))
    lines += nset("PIN", [mesh.node_at((a / 2, 0.0, a / 2))])
    lines += nset("PIN2", [mesh.node_at((a / 2, 0.0, a))])
    lines += neo_hooke("RUBBER", E, nu)
    lines += ["*SOLID SECTION, ELSET=EALL, MATERIAL=RUBBER",
              "** bottom: u_y = 0; centre of bottom u_x = u_z = 0; (0.05,0,0.1) u_x = 0",
              "*BOUNDARY", "BOT, 2, 2, 0.0", "PIN, 1, 1, 0.0", "PIN, 3, 3, 0.0",
              "PIN2, 1, 1, 0.0",
              "*STEP, NLGEOM, INC=1000",
              "*STATIC, DIRECT", "%.10g, 1.0" % (1.0 / ninc),
              "** top: u_y ramped linearly in the step to (stretch - 1) * 0.1",
              "*BOUNDARY", "TOP, 2, 2, %.10g" % ((stretch - 1.0) * a),
              "*NODE PRINT, NSET=TOP, TOTALS=ONLY", "RF",
              "*NODE PRINT, NSET=MIDH", "U",
              "*END STEP"]
    return lines


# --------------------------------------------------------------------------


def ccx_version():
    out = subprocess.run(["ccx", "-v"], capture_output=True, text=True).stdout
    m = re.search(r"Version\s+(\S+)", out)
    return m.group(1) if m else out.strip()


def run_ccx(workdir, deck):
    env = dict(os.environ, OMP_NUM_THREADS="1", CCX_NPROC_STIFFNESS="1",
               CCX_NPROC_EQUATION_SOLVER="1", CCX_NPROC_RESULTS="1")
    with open(os.path.join(workdir, deck + ".log"), "w") as log:
        r = subprocess.run(["ccx", "-i", deck], cwd=workdir, env=env,
                           stdout=log, stderr=subprocess.STDOUT)
    text = open(os.path.join(workdir, deck + ".log")).read()
    if r.returncode != 0 or "*ERROR" in text or "Job finished" not in text:
        sys.stderr.write(text[-3000:])
        raise RuntimeError("ccx failed on %s" % deck)
    return read_dat(os.path.join(workdir, deck + ".dat"))


def weighted(w, rows, comp):
    return sum(wt * rows[n][comp] for n, wt in w.items())


def write_json(out, doc):
    with open(os.path.join(out, doc["case"] + ".json"), "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


def main():
    out = os.path.abspath(sys.argv[1])
    os.makedirs(out, exist_ok=True)
    work = tempfile.mkdtemp(prefix="ccxref.")
    version = ccx_version()
    how = ("tools/calculix/make-references.sh (runs 'python3 tools/calculix/references.py "
           "tests/data/calculix', which writes the decks, runs 'OMP_NUM_THREADS=1 ccx -i <deck>' "
           "on each in a scratch folder and reads the nodal results from <deck>.dat)")

    for f in os.listdir(out):  # remove stale generated files
        if f.endswith((".inp", ".json")) or f == "README.md":
            os.remove(os.path.join(out, f))

    meshes = {}
    halves = [("LEFT", lambda c: c[0] < 0.5), ("RIGHT", lambda c: c[0] > 0.5)]

    def mesh(kind, dens, lo_hi, elsets):
        key = (kind, dens)
        if key not in meshes:
            n = CHECK_BAR if dens == "check" else DENSITIES[kind][dens]
            m = BoxMesh(lo_hi[0], lo_hi[1], n)
            fname = "mesh_%s_%s.inp" % (kind, dens)
            m.write(os.path.join(work if dens == "check" else out, fname), elsets)
            meshes[key] = (fname, m)
        return meshes[key]

    def run(deckname, lines, meshfile, keep=True):
        folder = out if keep else work
        with open(os.path.join(folder, deckname + ".inp"), "w") as f:
            f.write("\n".join(lines) + "\n")
        if keep:
            for fn in (deckname + ".inp", meshfile):
                shutil.copy(os.path.join(out, fn), work)
        return run_ccx(work, deckname)

    def mesh_info(m):
        return {"element": ELEMENT, "elements_xyz": list(m.n),
                "n_elements": len(m.elems), "n_nodes": len(m.coords)}

    docs = {}
    L, b, h = 1.0, 0.1, 0.1
    A, I = b * h, b * h ** 3 / 12
    rho = 100.0
    q = rho * G * A
    nu = 0.3
    kappa = 10 * (1 + nu) / (12 + 11 * nu)  # Cowper, rectangle
    stations = (0.25, 0.5, 0.75, 1.0)

    def cantilever_results(blocks, m, dens):
        line_b = block(blocks, "displacements", "LINE")
        line = line_b["rows"]
        xend = block(blocks, "displacements", "XEND")["rows"]
        rf = block(blocks, "total force", "FIX")["rows"]
        tip = line[m.node_at((1.0, 0.5, 0.0))]
        layer = rho * G * A * (L / m.n[0])  # weight of the first element layer
        return {
            "tip_centre_uy": tip[1],
            "tip_centre_ux": tip[0],
            "tip_face_mean_uy": weighted(m.plane_weights(0, 1.0), xend, 1),
            "centre_line_uy": {"x=%g" % x: line[m.node_at((x, 0.5, 0.0))][1] for x in stations},
            "centre_line_ux": {"x=%g" % x: line[m.node_at((x, 0.5, 0.0))][0] for x in stations},
            "ccx_RF_total_on_clamp_N": rf,
            "clamp_reaction_y_N": rf[1] + layer / 6,
            "final_step_time": line_b["time"],
        }

    cantilever_quantities = {
        "tip_centre_uy": "u_y of the node at (1, 0.5, 0), the centre of the free end",
        "tip_face_mean_uy": ("area mean of u_y over the x = 1 face (exact integral of the "
                             "quadratic face interpolant: corner nodes weight -A/12, mid-side "
                             "nodes +A/3 per element face)"),
        "centre_line_uy": "u_y of the nodes at (x, 0.5, 0)",
        "ccx_RF_total_on_clamp_N": ("ccx 'RF' summed over the clamped nodes; ccx's RF is the "
                                    "external force = reaction + the gravity load lumped on "
                                    "those nodes (1/6 of the first element layer's weight for "
                                    "C3D20R), so it is short of the weight by that amount"),
        "clamp_reaction_y_N": "ccx RF_y + weight of the first element layer / 6: the true reaction, equals the weight",
    }

    # ---- cases 1 and 3: linear cantilevers under gravity
    for case, E2 in (("cantilever_gravity", 1e6), ("two_material_cantilever_gravity", 4e6)):
        E1 = 1e6
        EI = lambda x: (E1 if x < 0.5 else E2) * I
        kGA = lambda x: kappa * (E1 if x < 0.5 else E2) / (2 * (1 + nu)) * A
        res = {}
        for dens in ("coarse", "fine", "check"):
            fname, m = mesh("bar", dens, BAR_GRAV, halves)
            deck = "%s_%s" % (case, dens)
            blocks = run(deck, cantilever_deck(deck, fname, m, E1, E2), fname, dens != "check")
            r = {"deck": deck + ".inp" if dens != "check" else None,
                 "mesh_file": fname if dens != "check" else None, "mesh": mesh_info(m)}
            r.update(cantilever_results(blocks, m, dens))
            del r["final_step_time"]
            res[dens] = r
        res["check"]["note"] = ("convergence check only: same deck on a %dx%dx%d mesh, written to "
                                "a scratch folder by the script and not kept" % CHECK_BAR)
        beam = {}
        eux, euy, _ = elastica(q, L, EI)
        for x in stations:
            wb, ws = beam_deflection(x, L, q, EI, kGA)
            beam["x=%g" % x] = {"euler_bernoulli_uy": -wb, "timoshenko_uy": -(wb + ws)}
        doc = {
            "case": case,
            "what": ("bar x in [0,1], y in [0.45,0.55], z in [-0.05,0.05] m; linear elastic, "
                     "small deformation (no NLGEOM); E = %g Pa for x < 0.5 and %g Pa for x > 0.5, "
                     "nu = 0.3, density 100 kg/m^3; x = 0 face clamped (u = 0 at every node of "
                     "the face); gravity g = 9.81 m/s^2 along -y (*DLOAD GRAV)" % (E1, E2)),
            "units": {"length": "m", "displacement": "m", "force": "N", "stress": "Pa"},
            "quantities": cantilever_quantities,
            "weight_N": q * L,
            "reference": res["fine"],
            "coarse": res["coarse"],
            "check": res["check"],
            "beam_theory": {
                "q_N_per_m": q, "EI_Nm2": {"x<0.5": E1 * I, "x>0.5": E2 * I},
                "shear_coefficient_cowper": kappa,
                "stations": beam,
                "elastica_tip_uy": euy, "elastica_tip_ux": eux,
                "elastica_note": ("geometrically exact (large-rotation) inextensible Euler-Bernoulli "
                                  "rod under the same load, for scale only: the reference itself is linear"),
            },
            "ccx_version": version,
            "how": how,
        }
        if E1 == E2:
            doc["beam_theory"]["qL4_over_8EI"] = q * L ** 4 / (8 * E1 * I)
        docs[case] = doc
        write_json(out, doc)

    # ---- case 2: two-material bar in tension
    case = "two_material_bar_tension"
    sigma = 1000.0
    res = {}
    for dens in ("coarse", "fine"):
        fname, m = mesh("tension", dens, BAR_TENS, halves)
        deck = "%s_%s" % (case, dens)
        blocks = run(deck, tension_deck(deck, fname, m), fname)
        xend = block(blocks, "displacements", "XEND")["rows"]
        xmid = block(blocks, "displacements", "XMID")["rows"]
        rf = block(blocks, "total force", "X0")["rows"]
        res[dens] = {
            "deck": deck + ".inp", "mesh_file": fname, "mesh": mesh_info(m),
            "end_face_mean_ux": weighted(m.plane_weights(0, 1.0), xend, 0),
            "mid_section_mean_ux": weighted(m.plane_weights(0, 0.5), xmid, 0),
            "end_centre_ux": xend[m.node_at((1.0, 0.0, 0.0))][0],
            "end_face_ux_min_max": [min(v[0] for v in xend.values()),
                                    max(v[0] for v in xend.values())],
            "mid_section_ux_min_max": [min(v[0] for v in xmid.values()),
                                       max(v[0] for v in xmid.values())],
            "x0_reaction_total_N": rf,
        }
    doc = {
        "case": case,
        "what": ("bar x in [0,1], y,z in [-0.05,0.05] m, no gravity; linear elastic, small "
                 "deformation; E = 1e6 Pa for x < 0.5, 4e6 Pa for x > 0.5, nu = 0.3; x = 0 face "
                 "u_x = 0 only, node (0,0,0) also u_y = u_z = 0, node (0,0,0.05) also u_y = 0 "
                 "(lateral contraction free); uniform traction 1000 Pa along +x on the x = 1 face "
                 "(*DLOAD <element>, P4, -1000: negative pressure = tension)"),
        "units": {"length": "m", "displacement": "m", "force": "N", "stress": "Pa"},
        "quantities": {
            "end_face_mean_ux": "area mean of u_x over the x = 1 face",
            "mid_section_mean_ux": "area mean of u_x over the section x = 0.5 (the material interface)",
            "end_centre_ux": "u_x of the node (1, 0, 0)",
            "x0_reaction_total_N": "sum of the reactions on the x = 0 face (check: -1000 Pa * 0.01 m^2 = -10 N in x)",
        },
        "reference": res["fine"],
        "coarse": res["coarse"],
        "closed_form": {
            "end_ux_series_springs": sigma * (0.5 / 1e6 + 0.5 / 4e6),
            "mid_ux": sigma * 0.5 / 1e6,
            "formula": "sigma*(0.5/E1 + 0.5/E2) and sigma*0.5/E1, sigma = 1000 Pa",
        },
        "ccx_version": version,
        "how": how,
    }
    docs[case] = doc
    write_json(out, doc)

    # ---- case 4: Neo-Hooke block
    case = "neo_hookean_block_compression"
    E, nu_b, a = 1e4, 0.3, 0.1
    mu, K = E / (2 * (1 + nu_b)), E / (3 * (1 - 2 * nu_b))
    C10, D1 = mu / 2, 2 / K
    res = {}
    for dens in ("coarse", "fine"):
        fname, m = mesh("block", dens, BLOCK, [])
        rows = []
        for tag, final, ninc, lams in (("compression", 0.5, 20, (0.9, 0.7, 0.5)),
                                       ("tension", 1.2, 20, (1.2,))):
            deck = "neo_hookean_block_%s_%s" % (tag, dens)
            blocks = run(deck, block_deck(deck, fname, m, final, ninc), fname)
            for lam in lams:
                t = (lam - 1.0) / (final - 1.0)
                F = block(blocks, "total force", "TOP", t)["rows"]
                u = block(blocks, "displacements", "MIDH", t)["rows"]
                xs0 = [n for n in u if abs(m.coords[n][0]) < 1e-12]
                xs1 = [n for n in u if abs(m.coords[n][0] - a) < 1e-12]
                w0 = sum(m.coords[n][0] + u[n][0] for n in xs0) / len(xs0)
                w1 = sum(m.coords[n][0] + u[n][0] for n in xs1) / len(xs1)
                lt, P = neo_hooke_uniaxial(lam, C10, D1)
                rows.append({
                    "stretch": lam, "deck": deck + ".inp", "step_time": round(t, 12),
                    "top_reaction_fy_N": F[1],
                    "nominal_stress_Pa": F[1] / (a * a),
                    "lateral_stretch": (w1 - w0) / a,
                    "analytic_nominal_stress_Pa": P,
                    "analytic_lateral_stretch": lt,
                })
        res[dens] = {"mesh_file": fname, "mesh": mesh_info(m), "results": rows}
    doc = {
        "case": case,
        "what": ("cube [0,0.1]^3 m, compressible Neo-Hooke (ccx *HYPERELASTIC, NEO HOOKE: "
                 "U = C10 (I1bar - 3) + (J - 1)^2 / D1, I1bar = J^(-2/3) tr C) with "
                 "C10 = mu/2, D1 = 2/K, mu = E/(2(1+nu)), K = E/(3(1-2nu)), E = 1e4 Pa, nu = 0.3; "
                 "NLGEOM; y = 0 face u_y = 0, node (0.05,0,0.05) u_x = u_z = 0, node (0.05,0,0.1) "
                 "u_x = 0; every node of the y = 0.1 face given u_y = (stretch - 1) * 0.1, free in "
                 "x and z (lateral faces traction free: homogeneous uniaxial stress); compression "
                 "ramped to stretch 0.5 in 20 fixed increments (stretches 0.9, 0.7, 0.5 read at "
                 "step times 0.2, 0.6, 1.0), tension ramped to stretch 1.2 in 20 fixed increments"),
        "units": {"length": "m", "force": "N", "stress": "Pa", "stretch": "1"},
        "material": {"E": E, "nu": nu_b, "mu": mu, "K": K, "C10": C10, "D1": D1},
        "quantities": {
            "top_reaction_fy_N": ("sum of the y reactions on the top-face nodes (the force the "
                                  "support exerts on the block: negative, pushing down, in compression)"),
            "nominal_stress_Pa": "top_reaction_fy_N / 0.01 m^2 (original area); negative in compression",
            "lateral_stretch": ("(mean deformed x of the x = 0.1 nodes at y = 0.05 - mean deformed "
                                "x of the x = 0 nodes at y = 0.05) / 0.1"),
            "analytic_*": "homogeneous uniaxial-stress solution of the same strain energy (python, bisection)",
        },
        "reference": res["fine"],
        "coarse": res["coarse"],
        "ccx_version": version,
        "how": how,
    }
    docs[case] = doc
    write_json(out, doc)

    # ---- case 5: Neo-Hooke cantilever, large sag
    case = "cantilever_neo_hookean_large"
    E5 = 1e5
    mu5, K5 = E5 / (2 * (1 + nu)), E5 / (3 * (1 - 2 * nu))
    res = {}
    for dens in ("coarse", "fine"):
        fname, m = mesh("bar", dens, BAR_GRAV, halves)
        deck = "%s_%s" % (case, dens)
        blocks = run(deck, cantilever_deck(deck, fname, m, E5, E5, nonlinear=True), fname)
        r = {"deck": deck + ".inp", "mesh_file": fname, "mesh": mesh_info(m)}
        r.update(cantilever_results(blocks, m, dens))
        if abs(r["final_step_time"] - 1.0) > 1e-9:
            raise RuntimeError("%s did not reach the end of the step" % deck)
        res[dens] = r
    eux, euy, eM0 = elastica(q, L, E5 * I)
    q5 = dict(cantilever_quantities)
    q5["tip_centre_ux"] = "u_x of the material point (1, 0.5, 0) (the tip moves back towards the wall)"
    q5["tip_face_mean_uy"] = "area mean of u_y over the x = 1 face (reference configuration)"
    doc = {
        "case": case,
        "what": ("the cantilever_gravity bar (x in [0,1], y in [0.45,0.55], z in [-0.05,0.05] m, "
                 "density 100 kg/m^3, x = 0 face clamped, gravity 9.81 m/s^2 along -y) with "
                 "compressible Neo-Hooke E = 1e5 Pa, nu = 0.3 (C10 = mu/2, D1 = 2/K as in "
                 "neo_hookean_block_compression), NLGEOM, gravity ramped over the step with "
                 "automatic increments (initial 0.05, max 0.1)"),
        "units": {"length": "m", "displacement": "m", "force": "N"},
        "material": {"E": E5, "nu": nu, "mu": mu5, "K": K5, "C10": mu5 / 2, "D1": 2 / K5,
                     "density": rho},
        "quantities": q5,
        "reference": res["fine"],
        "coarse": res["coarse"],
        "comparison": {
            "elastica_tip_ux": eux, "elastica_tip_uy": euy,
            "elastica_note": ("inextensible, shear-rigid Euler-Bernoulli rod with EI = E I "
                              "(initial modulus), exact large rotation (shooting, RK4)"),
            "elastica_root_moment_Nm": eM0,
            "elastica_root_surface_strain": eM0 / (E5 * I) * h / 2,
            "linear_small_deformation_tip_uy": -q * L ** 4 / (8 * E5 * I),
        },
        "ccx_version": version,
        "how": how,
    }
    docs[case] = doc
    write_json(out, doc)

    write_readme(out, docs, version)
    shutil.rmtree(work)


# --------------------------------------------------------------------------
# README


def pct(a, b):
    return "%+.3f %%" % (100.0 * (a - b) / b)


def write_readme(out, docs, version):
    c1 = docs["cantilever_gravity"]
    c2 = docs["two_material_bar_tension"]
    c3 = docs["two_material_cantilever_gravity"]
    c4 = docs["neo_hookean_block_compression"]
    c5 = docs["cantilever_neo_hookean_large"]
    f = lambda v: "%.6g" % v
    L = []
    w = L.append
    w("# CalculiX reference results")
    w("")
    w("Small static problems solved with the independent FEM code CalculiX (ccx %s, Debian "
      "package `calculix-ccx`), so that tests can compare ssc against them. SI units throughout "
      "(m, kg, s, N, Pa); gravity, where used, is 9.81 m/s^2 along -y." % version)
    w("")
    w("Everything in this folder (decks, meshes, JSON results and this README) is written by")
    w("`tools/calculix/make-references.sh` (about half a minute on one core; it needs `ccx` and")
    w("`python3`, standard library only). Do not edit the files by hand: change")
    w("`tools/calculix/references.py` and run the script again.")
    w("")
    w("## Files")
    w("")
    w("- `<case>.json`: one per case: the numbers (`reference` = fine mesh, `coarse` = coarse mesh,")
    w("  for the linear cantilevers also `check` = a third, finer mesh that is not kept), units,")
    w("  mesh and element type, the analytic comparison values, the ccx version and `how`.")
    w("- `<case>_<coarse|fine>.inp` (and `neo_hookean_block_<compression|tension>_*.inp`): the ccx")
    w("  decks; each reads its mesh with `*INCLUDE`, so run it next to its mesh file:")
    w("  `OMP_NUM_THREADS=1 ccx -i cantilever_gravity_fine` (ccx appends `.inp`).")
    w("- `mesh_<bar|tension|block>_<coarse|fine>.inp`: structured meshes of 20-node hexahedra")
    w("  (C3D20R: quadratic serendipity brick, 2x2x2 reduced integration) with element sets")
    w("  `EALL`, and for the bars `LEFT` (x < 0.5) and `RIGHT` (x > 0.5).")
    w("")
    w("Conventions used in the JSON files:")
    w("")
    w("- A *face mean* is the exact area mean of the quadratic face interpolant of the nodal")
    w("  values, i.e. per element face sum(w_i u_i) with weight -A/12 at the 4 corner nodes and")
    w("  +A/3 at the 4 mid-side nodes (these weights sum to A). It is not the plain average of")
    w("  the nodal values.")
    w("- Displacements are nodal values of the ccx solution; *centre line* means the nodes on the")
    w("  line y = 0.5, z = 0 (the bar's axis), which the meshes contain.")
    w("")

    # case 1/3 tables
    def cantilever_section(doc, title):
        r, c, k = doc["reference"], doc["coarse"], doc["check"]
        bt = doc["beam_theory"]["stations"]
        w("## " + title)
        w("")
        w(doc["what"][0].upper() + doc["what"][1:] + ".")
        w("")
        w("u_y in metres (negative = down). Meshes: coarse %s, fine (the reference) %s, check %s "
          "elements (x by y by z)." % tuple("x".join(map(str, d["mesh"]["elements_xyz"]))
                                             for d in (c, r, k)))
        w("")
        w("| quantity | coarse | **fine (reference)** | check | Euler-Bernoulli | EB + shear (Timoshenko) |")
        w("| --- | --- | --- | --- | --- | --- |")
        for x in ("x=0.25", "x=0.5", "x=0.75", "x=1"):
            w("| centre line u_y, %s | %s | **%s** | %s | %s | %s |" % (
                x, f(c["centre_line_uy"][x]), f(r["centre_line_uy"][x]), f(k["centre_line_uy"][x]),
                f(bt[x]["euler_bernoulli_uy"]), f(bt[x]["timoshenko_uy"])))
        w("| tip (x = 1) face mean u_y | %s | **%s** | %s | | |" % (
            f(c["tip_face_mean_uy"]), f(r["tip_face_mean_uy"]), f(k["tip_face_mean_uy"])))
        w("")
        tip_eb = bt["x=1"]["euler_bernoulli_uy"]
        if "qL4_over_8EI" in doc["beam_theory"]:
            w("Euler-Bernoulli q L^4 / (8 E I) = %s m with q = rho g A = %s N/m, I = b h^3/12 = "
              "%s m^4. The fine tip deflection is %s from it and %s from Euler-Bernoulli plus "
              "Timoshenko shear (Cowper's shear coefficient %.4f)." % (
                  f(doc["beam_theory"]["qL4_over_8EI"]), f(doc["beam_theory"]["q_N_per_m"]),
                  f(0.1 ** 4 / 12), pct(r["tip_centre_uy"], tip_eb),
                  pct(r["tip_centre_uy"], bt["x=1"]["timoshenko_uy"]),
                  doc["beam_theory"]["shear_coefficient_cowper"]))
        else:
            w("Beam values: the unit-load integral of M/EI(x) with EI stepping from %s to %s N m^2 "
              "at x = 0.5. The fine tip deflection is %s from Euler-Bernoulli and %s from "
              "Euler-Bernoulli plus shear." % (
                  f(doc["beam_theory"]["EI_Nm2"]["x<0.5"]), f(doc["beam_theory"]["EI_Nm2"]["x>0.5"]),
                  pct(r["tip_centre_uy"], tip_eb), pct(r["tip_centre_uy"], bt["x=1"]["timoshenko_uy"])))
        w("Tip face mean and tip centre differ by %s m (the end section hardly distorts). "
          "The true clamp reaction is %s N = the weight %s N." % (
              f(r["tip_face_mean_uy"] - r["tip_centre_uy"]), f(r["clamp_reaction_y_N"]),
              f(doc["weight_N"])))
        w("")
        d_cf = r["tip_centre_uy"] - c["tip_centre_uy"]
        d_fk = k["tip_centre_uy"] - r["tip_centre_uy"]
        ratio = d_cf / d_fk
        order = math.log(ratio) / math.log(2.0)
        extrap = k["tip_centre_uy"] + d_fk / (ratio - 1)
        w("Mesh convergence (tip centre): coarse to fine %s, fine to check %s; the observed "
          "order is %.2f (below the smooth-problem rate because of the stress singularity along "
          "the edges of the fully clamped face). Richardson extrapolation gives %s m, so the "
          "reference (fine) value is %s from the mesh limit and the coarse one %s." % (
              pct(r["tip_centre_uy"], c["tip_centre_uy"]), pct(k["tip_centre_uy"], r["tip_centre_uy"]),
              order, f(extrap), pct(r["tip_centre_uy"], extrap), pct(c["tip_centre_uy"], extrap)))
        w("")

    cantilever_section(c1, "1. `cantilever_gravity`")

    # case 2
    r, c, cf = c2["reference"], c2["coarse"], c2["closed_form"]
    w("## 2. `two_material_bar_tension`")
    w("")
    w(c2["what"][0].upper() + c2["what"][1:] + ".")
    w("")
    w("| quantity (m) | coarse %s | **fine %s (reference)** | closed form | fine vs closed form |" % (
        "x".join(map(str, c["mesh"]["elements_xyz"])), "x".join(map(str, r["mesh"]["elements_xyz"]))))
    w("| --- | --- | --- | --- | --- |")
    w("| x = 1 face mean u_x | %s | **%s** | %s = sigma (0.5/E1 + 0.5/E2) | %s |" % (
        f(c["end_face_mean_ux"]), f(r["end_face_mean_ux"]), f(cf["end_ux_series_springs"]),
        pct(r["end_face_mean_ux"], cf["end_ux_series_springs"])))
    w("| x = 0.5 section mean u_x | %s | **%s** | %s = sigma 0.5/E1 | %s |" % (
        f(c["mid_section_mean_ux"]), f(r["mid_section_mean_ux"]), f(cf["mid_ux"]),
        pct(r["mid_section_mean_ux"], cf["mid_ux"])))
    w("")
    w("The total reaction on x = 0 is %s N (traction times area, -10 N). The small deficit "
      "against the series-spring value is real 3D elasticity, not discretisation error: the two "
      "halves contract laterally by different amounts (nu sigma/E), the interface forces them to "
      "match, and the resulting local lateral stresses stiffen the bar near x = 0.5. Away from "
      "the interface the stress is uniaxial; u_x over the x = 1 face is uniform (fine mesh: "
      "spread %s m, min %s, max %s). Mesh convergence: coarse to fine changes the end value by %s "
      "and the mid value by %s." % (
          f(r["x0_reaction_total_N"][0]),
          f(r["end_face_ux_min_max"][1] - r["end_face_ux_min_max"][0]),
          f(r["end_face_ux_min_max"][0]), f(r["end_face_ux_min_max"][1]),
          pct(r["end_face_mean_ux"], c["end_face_mean_ux"]),
          pct(r["mid_section_mean_ux"], c["mid_section_mean_ux"])))
    w("")

    cantilever_section(c3, "3. `two_material_cantilever_gravity`")

    # case 4
    r, c, mat = c4["reference"], c4["coarse"], c4["material"]
    w("## 4. `neo_hookean_block_compression` (with one tension point)")
    w("")
    w(c4["what"][0].upper() + c4["what"][1:] + ".")
    w("")
    w("Material definition, from the CalculiX manual (*HYPERELASTIC): the NEO HOOKE potential is "
      "U = C10 (I1bar - 3) + (1/D1) (J - 1)^2 with I1bar = J^(-2/3) I1, I1 = tr C, J = det F; the "
      "data line is `C10, D1`. For small strain this has shear modulus mu = 2 C10 and bulk "
      "modulus K = 2/D1, hence C10 = mu/2 = %s Pa and D1 = 2/K = %s 1/Pa for E = 1e4 Pa, nu = 0.3 "
      "(mu = %s Pa, K = %s Pa). ccx 2.20 matches the homogeneous analytic solution of exactly "
      "this potential to 6-7 digits (table), which confirms the definition." % (
          f(mat["C10"]), f(mat["D1"]), f(mat["mu"]), f(mat["K"])))
    w("")
    w("| stretch | top reaction F_y (N) | nominal stress F_y / 0.01 m^2 (Pa) | lateral stretch | analytic nominal stress (Pa) | analytic lateral stretch |")
    w("| --- | --- | --- | --- | --- | --- |")
    for row in r["results"]:
        w("| %g | %s | %s | %s | %s | %s |" % (
            row["stretch"], f(row["top_reaction_fy_N"]), f(row["nominal_stress_Pa"]),
            f(row["lateral_stretch"]), f(row["analytic_nominal_stress_Pa"]),
            f(row["analytic_lateral_stretch"])))
    w("")
    dmax = max(abs(a["nominal_stress_Pa"] - b["nominal_stress_Pa"]) for a, b in
               zip(r["results"], c["results"]))
    w("The values are those of the fine mesh (%s elements); the coarse mesh (%s) gives the same "
      "numbers (largest nominal-stress difference %s Pa): the exact solution is a homogeneous "
      "deformation, which any mesh of these elements represents exactly, so there is no "
      "discretisation error here. Sign: F_y is the force the top support exerts on the block "
      "(negative = pushing down, compression). Small-strain check: at stretch 0.9, E * 0.1 = 1000 "
      "Pa against %s Pa; the lateral stretch 1 + nu * 0.1 = 1.03 against %s." % (
          "x".join(map(str, r["mesh"]["elements_xyz"])), "x".join(map(str, c["mesh"]["elements_xyz"])),
          "%.3g" % dmax, f(-r["results"][0]["nominal_stress_Pa"]), f(r["results"][0]["lateral_stretch"])))
    w("")

    # case 5
    r, c, cmp_ = c5["reference"], c5["coarse"], c5["comparison"]
    w("## 5. `cantilever_neo_hookean_large`")
    w("")
    w(c5["what"][0].upper() + c5["what"][1:] + ".")
    w("")
    w("| quantity (m) | coarse %s | **fine %s (reference)** | elastica |" % (
        "x".join(map(str, c["mesh"]["elements_xyz"])), "x".join(map(str, r["mesh"]["elements_xyz"]))))
    w("| --- | --- | --- | --- |")
    w("| tip centre u_y | %s | **%s** | %s |" % (f(c["tip_centre_uy"]), f(r["tip_centre_uy"]), f(cmp_["elastica_tip_uy"])))
    w("| tip centre u_x | %s | **%s** | %s |" % (f(c["tip_centre_ux"]), f(r["tip_centre_ux"]), f(cmp_["elastica_tip_ux"])))
    w("| tip face mean u_y | %s | **%s** | |" % (f(c["tip_face_mean_uy"]), f(r["tip_face_mean_uy"])))
    for x in ("x=0.25", "x=0.5", "x=0.75"):
        w("| centre line u_y, %s | %s | **%s** | |" % (x, f(c["centre_line_uy"][x]), f(r["centre_line_uy"][x])))
    w("")
    w("The linear small-deformation answer would be %s m (10 times case 1), which is meaningless "
      "here. The elastica (inextensible, shear-rigid rod, EI from the initial modulus, exact "
      "rotations) gives a tip deflection %s smaller than ccx; the difference is of the size of "
      "the shear deflection that the rod model lacks (about 1 %% in case 1) plus the material "
      "nonlinearity of the Neo-Hooke law: the rod model's root surface strain M(0) h / (2 E I) "
      "is %.0f %%. Mesh convergence: "
      "coarse to fine changes the tip u_y by %s." % (
          f(cmp_["linear_small_deformation_tip_uy"]),
          "%.2f %%" % (100.0 * (1.0 - cmp_["elastica_tip_uy"] / r["tip_centre_uy"])),
          100.0 * cmp_["elastica_root_surface_strain"],
          pct(r["tip_centre_uy"], c["tip_centre_uy"])))
    w("")

    w("## Caveats")
    w("")
    bt1 = c1["beam_theory"]
    w("- **Clamp.** The cantilevers are clamped by fixing all three displacement components of")
    w("  every node of the x = 0 face. This also stops the Poisson contraction and warping of the")
    w("  root section, so the FE bar is stiffer than a Timoshenko beam (the fine tip")
    w("  deflection of case 1 is %s from Euler-Bernoulli and %s from" % (
        pct(c1["reference"]["tip_centre_uy"], bt1["stations"]["x=1"]["euler_bernoulli_uy"]),
        pct(c1["reference"]["tip_centre_uy"], bt1["stations"]["x=1"]["timoshenko_uy"])))
    w("  Euler-Bernoulli plus shear), and the stress is singular along the edges of the clamped")
    w("  face, which slows mesh convergence (see the order above). A simulator that clamps")
    w("  differently (only some nodes, a penalty, a boundary layer of particles) will differ by")
    w("  about the shear-and-clamp effect, i.e. up to 1-2 % at the tip.")
    w("- **Small deformation in cases 1-3.** The sag of case 1 is 15 % of the length; a")
    w("  geometrically nonlinear solution of the same bar would be a few per cent smaller")
    w("  (the elastica gives %s m instead of %s m). The references are linear on purpose;" % (
        f(-bt1["elastica_tip_uy"]), f(bt1["qL4_over_8EI"])))
    w("  compare them with a linear (small-strain) solve or with a much smaller load.")
    w("- **ccx `RF`** is the external force at a node = reaction + applied load there. On the")
    w("  clamped face the gravity share of the face nodes (1/6 of the first element layer's")
    w("  weight) is included; the JSON gives both the raw sum and the corrected reaction.")
    w("- **Face traction in case 2** is `*DLOAD P4` (face 4 of the brick = its +x face), negative")
    w("  = tension; in a linear step it is a fixed (dead) load. The consistent nodal forces of a")
    w("  uniform pressure on a 20-node face are negative at its corner nodes (ccx manual), so")
    w("  compare load resultants, not nodal forces, with a code that uses other elements.")
    w("- **Case 4** is homogeneous, so it tests the constitutive law and the large-deformation")
    w("  kinematics, not the spatial discretisation. The top nodes are prescribed in y only and")
    w("  slide freely in x and z (frictionless platens).")
    w("- The HTML manual shipped by Debian (`calculix-ccx-doc`) is for version 2.11; the solver is")
    w("  2.20. The keywords used here (*NODE, *ELEMENT C3D20R, *ELSET, *NSET, *INCLUDE, *MATERIAL,")
    w("  *ELASTIC, *HYPERELASTIC NEO HOOKE, *DENSITY, *SOLID SECTION, *BOUNDARY, *STEP NLGEOM INC,")
    w("  *STATIC DIRECT, *DLOAD GRAV / Pn, *NODE PRINT U / RF TOTALS) are unchanged between the two.")
    w("")
    with open(os.path.join(out, "README.md"), "w") as fh:
        fh.write("\n".join(L) + "\n")


if __name__ == "__main__":
    main()
