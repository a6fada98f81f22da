#!/usr/bin/env python3
"""World E: an independent simulator of a skid-steer rover's motor power.

Written from the thesis alone (skid-steer kinematics Eq 1.1-1.8 and 2.1-2.10, Appendix A; the
ICR power model Eq 1.16 / paper Eq 18-22; DC motor Eq 1.17-1.19; 2D slip-sinkage Eq 5.15-5.28;
sand bulldozing Eq 5.29-5.39; angular slip Eq 6.3; slip track Appendix D).  Python 3 standard
library only.

    python3 gen.py --seed S --out DIR [--count-per-class K]

writes DIR/<class>-<seed>-<k>/{rover.toml, cal_0.csv, cal_1.csv, run_0.csv, run_1.csv,
run_2.csv, truth.json} for the control class and the eight catalogued effects.  See README.md
beside this file for the physics and the conventions.

Construction (different from a per-side split of Eq 1.16): every wheel is a contact patch with
(elliptic) Coulomb friction.  Given the two side rim speeds, the body twist (forward speed v,
lateral speed u, yaw rate w) is solved from the rover's force and moment balance; each wheel's
friction force follows its own slip velocity (hub velocity minus rim velocity), and a side's
motor supplies the longitudinal friction of its two wheels times its rim speed.  The inner side
thus brakes (R > R') or drives (R < R') by itself, and the power summed over the sides equals the
friction dissipation of Eq 1.16 with the terrain's slip track.
"""

import argparse
import json
import math
import os
import random
import sys
import time

G0 = 9.81

EFFECTS = [
    "inner-drag",
    "sinkage-bulldozing",
    "angular-slip",
    "slip-track",
    "braked-inner",
    "current-offset",
    "motor-heating",
    "slope",
]
CLASSES = ["control"] + EFFECTS
TERRAIN_EFFECTS = {"inner-drag", "sinkage-bulldozing", "angular-slip", "slip-track",
                   "braked-inner", "slope"}
HARDWARE_EFFECTS = {"current-offset", "motor-heating"}
FIXED_REGIME = {
    "inner-drag": "dragged-inner",
    "angular-slip": "at-r-prime",
    "slip-track": "all",
    "braked-inner": "at-r-prime",
    "current-offset": "all",
    "motor-heating": "all",
    "slope": "all",
}

# The thesis' turn set (R/R'), Sections 4.4 and 5 (plus 3R'); None is the straight line.
TURN_SET = [0.0, 1.0 / 3.0, 2.0 / 3.0, 0.8, 1.0, 4.0 / 3.0, 2.0, 3.0, None]
CAL_SET = [0.0, 2.0, 3.0, None]

ROVERS = {
    # Table 3.2 (geometry, mass, controller slip track) and Table 5.1 (wheel, soil model).
    "husky": {
        "name": "Clearpath Husky A200",
        "B": 0.545, "L": 0.52, "r": 0.165, "m": 63.0, "Bs": 1.10, "h_cg": 0.20,
        "vbat": (25.0, 26.2), "r_int": (0.04, 0.12), "r_wire": (0.003, 0.012),
        "i_aux": (0.6, 1.8), "k_w": (2.7, 3.4), "R_w": (0.06, 0.14),
        "G": (25.0, 60.0), "mux": (0.6, 1.0), "s0": (0.0, 0.10),
        "Bw": 0.125, "e_cw": 1.05, "n_g": 28, "h_g": 0.015, "B_g": 0.085, "l_g": 0.011,
        "h_gc": 0.13, "d0": 0.010, "lam": 0.7, "k_bekker": (0.3e6, 0.8e6),
        "soc_v_per_as": 2.0 / (20.0 * 3600.0), "i_motor_max": 40.0,
    },
    # Table 3.1 (B_s = B: the Argo's controller uses the track width).  The wheel values are
    # not in the thesis; they scale the Husky's with the wheel radius.
    "argo": {
        "name": "Argo J5",
        "B": 1.14, "L": 0.98, "r": 0.30, "m": 372.0, "Bs": 1.14, "h_cg": 0.35,
        "vbat": (49.5, 52.5), "r_int": (0.03, 0.08), "r_wire": (0.003, 0.010),
        "i_aux": (1.5, 3.5), "k_w": (11.0, 13.5), "R_w": (0.08, 0.20),
        "G": (150.0, 280.0), "mux": (1.1, 1.8), "s0": (0.04, 0.10),
        "Bw": 0.25, "e_cw": 1.0, "n_g": 24, "h_g": 0.025, "B_g": 0.20, "l_g": 0.02,
        "h_gc": 0.25, "d0": 0.015, "lam": 0.7, "k_bekker": (0.3e6, 0.8e6),
        "soc_v_per_as": 4.0 / (60.0 * 3600.0), "i_motor_max": 80.0,
    },
}

# GRC-1 simulant, Table 3.3
SOIL = {"phi_i": math.radians(42.0), "rho": 1788.5, "phi_r": math.radians(42.0)}


def u(rng, lo_hi):
    return rng.uniform(lo_hi[0], lo_hi[1])


# --------------------------------------------------------------------------------------------
# commands (Eq 2.6, Appendix A Eq A.13/A.14) and regimes
# --------------------------------------------------------------------------------------------

def side_speeds(vc, ratio, r_prime):
    """(inner, outer) commanded side speeds for a turn of R = ratio * R' (None: straight)."""
    if ratio is None:
        return vc, vc
    R = ratio * r_prime
    if abs(ratio - 1.0) < 1e-12:
        return 0.0, 2.0 * vc
    if R < r_prime:
        v_in = 2.0 * vc / ((R + r_prime) / (R - r_prime) - 1.0)
        return v_in, 2.0 * vc + v_in
    v_in = 2.0 * vc / ((R + r_prime) / (R - r_prime) + 1.0)
    return v_in, 2.0 * vc - v_in


def regime_of(ratio, rover):
    if ratio is None:
        return "straight"
    if ratio == 0.0:
        return "point"
    if abs(ratio - 1.0) < 1e-12:
        return "at-r-prime"
    R = ratio * rover["Bs"] / 2.0
    if ratio > 1.0:
        return "above-r-prime"
    if R < rover["B"] / 2.0 - 1e-9:
        return "below-half-track"
    return "dragged-inner"


def ratio_key(ratio):
    return "S" if ratio is None else "%.4f" % ratio


# --------------------------------------------------------------------------------------------
# world and effect draws
# --------------------------------------------------------------------------------------------

def draw_world(seed, cls, k):
    rs = random.Random("worldE|%s|%s|%s|structure" % (seed, cls, k))
    rover_id = "argo" if rs.random() < 1.0 / 3.0 else "husky"
    rv = ROVERS[rover_id]
    w = {"rover": rover_id}
    w["rate_hz"] = rs.choice([50, 100])
    w["direction"] = rs.choice(["left", "right"])
    w["v_c"] = round(rs.uniform(0.2, 0.45), 3)
    w["turn_deg"] = rs.choice([90, 180, 270])
    w["straight_s"] = round(rs.uniform(3.0, 5.0), 2)
    # terrain (reference patch and test terrain share it unless a terrain effect changes it)
    w["mu_x"] = u(rs, rv["mux"])
    w["terrain_angular_slip"] = u(rs, rv["s0"])
    w["terrain_slip_track_m"] = rv["Bs"] / (1.0 - w["terrain_angular_slip"])
    w["mu_sigma"] = rs.uniform(0.01, 0.04)
    w["eps_mps"] = rs.uniform(0.010, 0.030)
    g = u(rs, rv["G"])
    w["G_side_n"] = [g * rs.uniform(0.95, 1.05), g * rs.uniform(0.95, 1.05)]
    # motors and drivers (Eq 1.17-1.19), one brushed DC motor per side, values at the wheel shaft
    kw = u(rs, rv["k_w"])
    rw = u(rs, rv["R_w"])
    w["k_w"] = [kw * rs.uniform(0.97, 1.03), kw * rs.uniform(0.97, 1.03)]
    w["R_w_ohm"] = [rw * rs.uniform(0.95, 1.05), rw * rs.uniform(0.95, 1.05)]
    w["eta_gear"] = rs.uniform(0.85, 0.95)
    w["eta_driver"] = rs.uniform(0.90, 0.97)
    if rs.random() < 0.5:
        w["regen"] = "returned"
        w["regen_fraction"] = rs.uniform(0.3, 0.8)
    else:
        w["regen"] = "clamped"
        w["regen_fraction"] = 0.0
    w["i_quiescent_a"] = [rs.uniform(0.0, 0.15), rs.uniform(0.0, 0.15)]
    # battery and wiring (bus sag)
    w["v_battery_v"] = u(rs, rv["vbat"])
    w["r_internal_ohm"] = u(rs, rv["r_int"])
    w["r_wire_ohm"] = [u(rs, rv["r_wire"]), u(rs, rv["r_wire"])]
    w["i_aux_a"] = u(rs, rv["i_aux"])
    # sensors
    w["current_noise_a"] = rs.uniform(0.02, 0.06)
    w["bus_noise_v"] = rs.uniform(0.0015, 0.004)
    w["yaw_noise_rad"] = 0.0003
    w["pitch_noise_deg"] = 0.03
    # drive dynamics
    w["accel_mps2"] = rs.uniform(2.0, 5.0)
    w["t_ambient_c"] = rs.uniform(15.0, 30.0)
    return w


def draw_effect(seed, cls, k, world):
    if cls == "control":
        return None
    re = random.Random("worldE|%s|%s|%s|effect" % (seed, cls, k))
    rv = ROVERS[world["rover"]]
    e = {"id": cls}
    if cls == "inner-drag":
        # Section 5.2: ~70 % more inner-wheel torque at 2R'/3 (excavating the pile ahead)
        e["c_drag"] = re.uniform(0.25, 0.7)          # extra torque / (p r)
        e["tau_pile_s"] = re.uniform(0.5, 2.5)       # the pile builds up over the turn
    elif cls == "sinkage-bulldozing":
        e["k_f"] = 0.85 * re.uniform(0.8, 1.2)        # Section 5.3.1 tuned values
        e["k_s"] = 0.35 * re.uniform(0.8, 1.2)
        e["k_f_counter"] = re.uniform(0.3, 0.6)
        e["k_bekker"] = u(re, rv["k_bekker"])         # compaction resistance of the sinkage
        e["strength"] = re.uniform(0.2, 0.8)          # scale on Eq 5.35 and the compaction
    elif cls == "angular-slip":
        e["peak"] = re.uniform(0.12, 0.35)            # extra s_w at R' (Eq 6.3, Fig 6.8)
        e["at_point_fraction"] = re.uniform(0.25, 0.5)
        e["decay_above"] = re.uniform(0.5, 1.0)
    elif cls == "slip-track":
        if world["rover"] == "argo":
            f = re.uniform(1.15, 1.4)
        else:
            f = re.uniform(0.72, 0.88) if re.random() < 0.4 else re.uniform(1.15, 1.35)
        e["factor"] = f
        e["test_slip_track_m"] = world["terrain_slip_track_m"] * f
    elif cls == "braked-inner":
        e["kappa"] = re.uniform(0.15, 0.5)            # Fig 6.11: a braked wheel resists more
    elif cls == "current-offset":
        mode = re.choice(["left", "right", "both"])
        e["mode"] = mode
        e["offset_a"] = [re.uniform(0.3, 0.8) if mode in ("left", "both") else 0.0,
                         re.uniform(0.3, 0.8) if mode in ("right", "both") else 0.0]
    elif cls == "motor-heating":
        # winding thermal resistance and mass: sized so that continuous point turning would
        # settle 60-120 K above ambient with a time constant of 1-3 minutes
        p_cu = reference_copper_loss(world)
        e["r_thermal_k_per_w"] = re.uniform(60.0, 120.0) / p_cu
        e["c_thermal_j_per_k"] = re.uniform(60.0, 180.0) / e["r_thermal_k_per_w"]
        e["alpha_per_k"] = 0.00393                    # copper
        e["k_tempco_per_k"] = re.uniform(0.001, 0.002)  # magnets weaken: more current per torque
    elif cls == "slope":
        e["incline_deg"] = re.uniform(3.0, 9.0)
        e["uphill_azimuth_rad"] = re.uniform(0.0, 2.0 * math.pi)
    return e


def reference_copper_loss(world):
    """Copper loss of one side's motor in a steady point turn on the reference patch."""
    rv = ROVERS[world["rover"]]
    p = rv["m"] * G0 / 4.0
    fx = world["mu_x"] * math.sqrt(max(0.0, 1.0 - rv["B"] / world["terrain_slip_track_m"])) * p
    tau = rv["r"] * (2.0 * fx + world["G_side_n"][0])
    i = tau / (world["k_w"][0] * world["eta_gear"])
    return i * i * world["R_w_ohm"][0]


def draw_plans(seed, cls, k, world, effect):
    """Manoeuvre orders, standstills and per-manoeuvre mu variation, shared with the twin."""
    plans = []
    for name in ["cal_0", "cal_1", "run_0", "run_1", "run_2"]:
        rp = random.Random("worldE|%s|%s|%s|plan|%s" % (seed, cls, k, name))
        if name.startswith("cal"):
            order = CAL_SET[:]
            rp.shuffle(order)
        else:
            reps = 3 if (effect is not None and effect["id"] == "motor-heating") else 1
            order = []
            for _ in range(reps):
                o = TURN_SET[:]
                rp.shuffle(o)
                order += o
        man = []
        for ratio in order:
            man.append({
                "ratio": ratio,
                "mu_mult": max(0.85, 1.0 + world["mu_sigma"] * rp.gauss(0.0, 1.0)),
                "pause_s": round(rp.uniform(1.5, 2.3), 2),
            })
        plans.append({
            "name": name,
            "test": name.startswith("run"),
            "initial_s": round(rp.uniform(3.0, 3.8), 2),
            "manoeuvres": man,
            "noise_seed": "worldE|%s|%s|%s|noise|%s" % (seed, cls, k, name),
        })
    return plans


# --------------------------------------------------------------------------------------------
# contact mechanics and the rover's force/moment balance
# --------------------------------------------------------------------------------------------

class Body:
    """Geometry and the current contact state of the rover."""

    def __init__(self, rv, world):
        self.B = rv["B"]
        self.L = rv["L"]
        self.r = rv["r"]
        self.m = rv["m"]
        self.h = rv["h_cg"]
        hl, hb = self.L / 2.0, self.B / 2.0
        # (x forward, y left, side 0 = left / 1 = right)
        self.wheels = [(hl, hb, 0), (-hl, hb, 0), (hl, -hb, 1), (-hl, -hb, 1)]
        self.Iz = self.m * (self.L ** 2 + self.B ** 2) / 12.0
        self.eps = world["eps_mps"]

    def loads(self, pitch, roll):
        n = self.m * G0 * math.cos(pitch) * math.cos(roll)
        dp = self.m * G0 * math.sin(pitch) * self.h / self.L
        dr = self.m * G0 * math.sin(roll) * self.h / self.B
        out = []
        for (x, y, _s) in self.wheels:
            out.append(max(0.05 * n, n / 4.0 - (x / self.L) * dp - (y / self.B) * dr))
        return out


def anisotropy_for(slip_track, B, L):
    """(mu_y/mu_x)^2 that puts the side ICRs at +-slip_track/2 (moment balance, point turn)."""
    return max(1e-4, (slip_track - B) * B / (L * L))


def contact_forces(body, tw, vl, vr, p, mux, muy, drag_c, drag_b):
    """Per-wheel friction (elliptic Coulomb, regularised) and external drags.

    Returns lists fx (longitudinal force on the wheel at the contact: loads the motor), the body
    force totals and the moment, and the hub velocities."""
    v, uu, w = tw
    mux2 = mux * mux
    muy2 = muy * muy
    e2 = (muy * body.eps) ** 2
    fx_w = [0.0] * 4
    hubs = [None] * 4
    FX = FY = MZ = 0.0
    for i, (x, y, s) in enumerate(body.wheels):
        V = vl if s == 0 else vr
        hx = v - w * y
        hy = uu + w * x
        sx = hx - V
        sy = hy
        q = math.sqrt(mux2 * sx * sx + muy2 * sy * sy + e2)
        Fx = -p[i] * mux2 * sx / q
        Fy = -p[i] * muy2 * sy / q
        hn = None
        if drag_c is not None and drag_c[i] > 0.0:
            hn = math.sqrt(hx * hx + hy * hy + body.eps * body.eps)
            Fx -= drag_c[i] * hx / hn
            Fy -= drag_c[i] * hy / hn
        fx_w[i] = Fx
        Bx, By = Fx, Fy
        if drag_b is not None and drag_b[i] > 0.0:
            if hn is None:
                hn = math.sqrt(hx * hx + hy * hy + body.eps * body.eps)
            Bx -= drag_b[i] * hx / hn
            By -= drag_b[i] * hy / hn
        FX += Bx
        FY += By
        MZ += x * By - y * Bx
        hubs[i] = (hx, hy)
    return fx_w, FX, FY, MZ, hubs


def solve_twist(body, vl, vr, p, mux, muy, gx, gy, drag_c, drag_b, guess):
    """Steady twist (v, u, w) from the force and moment balance (Newton, numeric Jacobian)."""
    W = body.m * G0
    Lc = body.L

    def res(t):
        _f, FX, FY, MZ, _h = contact_forces(body, t, vl, vr, p, mux, muy, drag_c, drag_b)
        return [(FX + gx) / W, (FY + gy) / W, MZ / (W * Lc)]

    x = list(guess)
    r0 = res(x)
    n0 = sum(c * c for c in r0)
    for _it in range(40):
        if n0 < 1e-22:
            break
        J = [[0.0] * 3 for _ in range(3)]
        for j in range(3):
            h = 1e-7 * max(1.0, abs(x[j])) + 1e-8
            xp = x[:]
            xp[j] += h
            rp = res(xp)
            for i in range(3):
                J[i][j] = (rp[i] - r0[i]) / h
        dx = solve3(J, [-c for c in r0])
        if dx is None:
            break
        step = 1.0
        while True:
            xn = [x[i] + step * dx[i] for i in range(3)]
            rn = res(xn)
            nn = sum(c * c for c in rn)
            if nn < n0 or step < 1e-4:
                break
            step *= 0.5
        x, r0, n0 = xn, rn, nn
    return x


def solve3(A, b):
    M = [A[i][:] + [b[i]] for i in range(3)]
    for c in range(3):
        piv = max(range(c, 3), key=lambda i: abs(M[i][c]))
        if abs(M[piv][c]) < 1e-300:
            return None
        M[c], M[piv] = M[piv], M[c]
        for i in range(3):
            if i != c:
                f = M[i][c] / M[c][c]
                for j in range(c, 4):
                    M[i][j] -= f * M[c][j]
    return [M[i][3] / M[i][i] for i in range(3)]


# --------------------------------------------------------------------------------------------
# 2D slip-sinkage (Eq 5.15-5.28) and bulldozing (Eq 5.29-5.39)
# --------------------------------------------------------------------------------------------

class Sinkage:
    def __init__(self, rv, eff):
        self.r = rv["r"]
        self.lam = rv["lam"]
        self.Bw = rv["Bw"]
        self.Bc = rv["e_cw"] * rv["Bw"]                                      # Eq 5.18
        self.h = rv["h_g"]
        self.kex = 1.0 - rv["n_g"] * rv["B_g"] * rv["l_g"] / (2.0 * math.pi * self.r * self.Bc)  # 5.20
        self.d0 = rv["d0"]
        self.hgc = rv["h_gc"]
        self.kf = eff["k_f"]
        self.kf_counter = eff["k_f_counter"]
        self.ks = eff["k_s"]
        self.kb = eff["k_bekker"]
        self.strength = eff["strength"]
        self.reset()

    def reset(self):
        self.d = [self.d0] * 4
        self.xw = [0.0] * 4

    def w_g(self, d):
        davg = (1.0 + self.lam) * d / 2.0                                     # Eq 5.25
        return 2.0 * math.sqrt(max(0.0, davg * (2.0 * self.r - davg))), davg  # Eq 5.26

    def step(self, i, v_cmd, hub, dt):
        hx, hy = hub
        vact = math.hypot(hx, hy)
        if vact > 1e-9:
            if abs(v_cmd) > 1e-9:
                cb = hx * (1.0 if v_cmd > 0 else -1.0) / vact
            else:
                cb = abs(hx) / vact
            sb = abs(hy) / vact
        else:
            cb, sb = 1.0, 0.0
        d = self.d[i]
        th_f = math.acos(max(-1.0, 1.0 - d / self.r))                         # Eq 5.15
        th_r = math.acos(max(-1.0, 1.0 - self.lam * d / self.r))              # Eq 5.16
        wc = self.r * (th_f + th_r)                                           # Eq 5.17
        v_rem = self.kex * self.Bc * self.h * abs(v_cmd) * dt                 # Eq 5.19
        dy = vact * dt * cb                                                   # Eq 5.21
        dxs = vact * dt * sb                                                  # Eq 5.22
        wg, _davg = self.w_g(d)
        # Eq 5.23/24/27.  With the wheel rotating against its motion (beta > 90 deg, Section
        # 5.3.2, Appendix B) the sand met at the front is excavated away by the grousers: it is
        # added at a reduced rate, so the wheel sinks faster and deeper but to a steady state.
        kf = self.kf if dy >= 0.0 else self.kf * self.kf_counter
        v_add = kf * abs(dy) * self.Bw * d + self.ks * dxs * wg * d
        d = d + (v_rem - v_add) / (self.Bc * wc)                              # Eq 5.28
        self.d[i] = min(self.hgc, max(self.d0, d))
        self.xw[i] += vact * dt
        return sb

    def bulldozing(self, i, sin_beta):
        """Eq 5.35 minimised over the failure angle, the pile capped at its repose (Eq 5.36)."""
        d = self.d[i]
        wg, davg = self.w_g(d)
        if davg <= 0.0:
            return 0.0
        phi = SOIL["phi_i"]
        h_max = wg * math.tan(SOIL["phi_r"])                                  # Eq 5.36
        x_max = h_max * h_max / (2.0 * davg * math.tan(phi))                  # Eq 5.33 pile
        xw = min(self.xw[i], x_max)
        w = wg * sin_beta                                                     # Eq 5.31
        best = None
        lo, hi = math.radians(0.5), math.pi / 2.0 - phi - math.radians(0.5)
        for n in range(24):
            X = lo + (hi - lo) * n / 23.0
            val = (davg / math.tan(X) + 2.0 * xw) / (1.0 / math.tan(X + phi))
            if best is None or val < best:
                best = val
        f = w * SOIL["rho"] * G0 * davg / 2.0 * best                          # Eq 5.35
        return self.strength * f

    def compaction(self, i):
        """Bekker compaction resistance of the extra sinkage (n = 1), per wheel."""
        d = self.d[i]
        return self.strength * self.kb * self.Bw * (d * d - self.d0 * self.d0) / 2.0


# --------------------------------------------------------------------------------------------
# one run
# --------------------------------------------------------------------------------------------

class DatasetState:
    """Hardware state that carries over from run to run (battery charge)."""

    def __init__(self, world):
        self.charge_as = 0.0


def angular_slip_extra(eff, ratio):
    if ratio is None:
        return 0.0
    x = ratio
    if x <= 1.0:
        return eff["peak"] * (eff["at_point_fraction"] + (1.0 - eff["at_point_fraction"]) * x)
    return eff["peak"] * math.exp(-(x - 1.0) / eff["decay_above"])


def simulate_run(world, effect, plan, dstate):
    rv = ROVERS[world["rover"]]
    body = Body(rv, world)
    eid = effect["id"] if effect is not None else None
    test = plan["test"]
    terrain_eff = eid if (eid in TERRAIN_EFFECTS and test) else None
    hw_eff = eid if eid in HARDWARE_EFFECTS else None
    dt = 1.0 / world["rate_hz"]
    rn = random.Random(plan["noise_seed"])
    r_prime = rv["Bs"] / 2.0
    vc = world["v_c"]
    left = world["direction"] == "left"
    turn_rad = math.radians(world["turn_deg"])

    # terrain
    slip_track = world["terrain_slip_track_m"]
    if terrain_eff == "slip-track":
        slip_track = effect["test_slip_track_m"]
    mux0 = world["mu_x"]
    muy0 = mux0 * math.sqrt(anisotropy_for(world["terrain_slip_track_m"], body.B, body.L))
    if slip_track != world["terrain_slip_track_m"]:
        # Appendix D/E: the terrain's slip track moves with the wheels' longitudinal grip
        # (loose soil slips more); the lateral friction stays
        mux0 = muy0 / math.sqrt(anisotropy_for(slip_track, body.B, body.L))
    sink = Sinkage(rv, effect) if terrain_eff == "sinkage-bulldozing" else None

    # motors
    kw = world["k_w"]
    Rw0 = world["R_w_ohm"]
    eta_g = world["eta_gear"]
    eta_d = world["eta_driver"]
    regen_frac = world["regen_fraction"] if world["regen"] == "returned" else 0.0
    T = [world["t_ambient_c"], world["t_ambient_c"]]
    heating = hw_eff == "motor-heating"
    offs = effect["offset_a"] if hw_eff == "current-offset" else [0.0, 0.0]
    iq = world["i_quiescent_a"]
    Gs = world["G_side_n"]
    i_max = rv["i_motor_max"]

    # battery
    vbus = [world["v_battery_v"], world["v_battery_v"]]
    ibus = [iq[0], iq[1]]

    yaw = 0.0
    t = 0.0
    rows = []
    records = []
    cmd_vec = (0.0, 0.0)     # the last non-zero command (for the ramp down)
    a = 0.0                  # ramp factor of the wheel speeds
    twist_ss = (0.0, 0.0, 0.0)
    eps_s = 0.005

    def slope_angles(psi):
        if terrain_eff != "slope":
            return 0.0, 0.0
        th = math.radians(effect["incline_deg"])
        rel = psi - effect["uphill_azimuth_rad"]
        pitch = math.asin(math.sin(th) * math.cos(rel))
        roll = -math.asin(math.sin(th) * math.sin(rel))
        return pitch, roll

    def emit(cmd_l, cmd_r, man):
        nonlocal yaw, t, a, ibus, vbus
        vl_c, vr_c = cmd_vec
        vmax = max(abs(vl_c), abs(vr_c), 1e-6)
        da = world["accel_mps2"] * dt / vmax
        on = (cmd_l != 0.0 or cmd_r != 0.0)
        a_prev = a
        a = min(1.0, a + da) if on else max(0.0, a - da)
        adot = (a - a_prev) / dt
        vl, vr = a * vl_c, a * vr_c
        pitch, roll = slope_angles(yaw)
        p = body.loads(pitch, roll)
        if man is not None:
            mux, muy = man["mux"], man["muy"]
        else:
            mux, muy = mux0, muy0
        v, uu, w = (a * twist_ss[0], a * twist_ss[1], a * twist_ss[2])
        drag_c = man["drag_c"] if man is not None else None
        drag_b = man["drag_b"] if man is not None else None
        if a > 0.0:
            fx_w, _FX, _FY, _MZ, hubs = contact_forces(body, (v, uu, w), vl, vr, p, mux, muy,
                                                      drag_c, drag_b)
        else:
            fx_w, hubs = [0.0] * 4, [(0.0, 0.0)] * 4
        # inertia, shared by the sides in proportion to their rim speed
        sv = abs(vl) + abs(vr)
        p_in = (body.m * v * twist_ss[0] * adot + body.Iz * w * twist_ss[2] * adot)
        f_in = p_in / sv if sv > 1e-6 else 0.0
        side_f = [0.0, 0.0]
        for i, (_x, _y, s) in enumerate(body.wheels):
            V = vl if s == 0 else vr
            sg = V / math.sqrt(V * V + eps_s * eps_s)
            f = fx_w[i] + 0.5 * Gs[s] * sg
            if sink is not None and man is not None and a > 0.0:
                sb = sink.step(i, V, hubs[i], dt)
                man["sin_beta"][i] = sb
                f += min(0.2 * p[i], sink.compaction(i)) * sg
            if man is not None and man.get("inner_drag") and a > 0.0:
                if s == man["inner_side"]:
                    hx = hubs[i][0]
                    if hx * V < 0.0:          # dragged: hub moves against the rim
                        tau_t = man["t_on"]
                        f += effect["c_drag"] * p[i] * (1.0 - math.exp(-tau_t / effect["tau_pile_s"])) * sg
            side_f[s] += f
        meas = []
        for s in range(2):
            V = vl if s == 0 else vr
            F = side_f[s]
            # inertia: power shared in proportion to |V|, i.e. force P_in/(|Vl|+|Vr|) * sign V
            if sv > 1e-6:
                F += f_in * (1.0 if V >= 0 else -1.0)
            tau = F * body.r
            Om = V / body.r
            if heating:
                dT = T[s] - world["t_ambient_c"]
                Rw = Rw0[s] * (1.0 + effect["alpha_per_k"] * dT)
                k = kw[s] * (1.0 - effect["k_tempco_per_k"] * dT)
            else:
                Rw, k = Rw0[s], kw[s]
            if Om == 0.0:
                # a held wheel (the inner side at R'): the speed loop holds it against the
                # dragging load; the gears' static friction helps (Eq 1.17 with w_m = 0:
                # copper loss only)
                I = tau * eta_g * eta_g / k
            elif tau * Om > 0.0:
                I = tau / (k * eta_g)
            else:
                I = tau * eta_g / k
            I = max(-i_max, min(i_max, I))          # the driver's current limit
            U = k * Om + Rw * I
            Pm = U * I
            if Pm >= 0.0:
                Pb = Pm / eta_d
            else:
                Pb = Pm * eta_d * regen_frac
            ib = Pb / vbus[s] + iq[s]
            meas.append(ib)
            if heating:
                cth = effect["c_thermal_j_per_k"]
                rth = effect["r_thermal_k_per_w"]
                T[s] += (I * I * Rw - (T[s] - world["t_ambient_c"]) / rth) * dt / cth
                T[s] = min(T[s], world["t_ambient_c"] + 150.0)   # the driver's thermal cut-back
        ibus = meas
        itot = ibus[0] + ibus[1] + world["i_aux_a"]
        dstate.charge_as += itot * dt
        voc = world["v_battery_v"] - ROVERS[world["rover"]]["soc_v_per_as"] * dstate.charge_as
        vbus = [max(0.5 * voc, voc - world["r_internal_ohm"] * itot
                    - world["r_wire_ohm"][s] * ibus[s]) for s in range(2)]
        # sensors (INA226: 1.25 mV, 0.5 mA)
        il = ibus[0] + offs[0] + rn.gauss(0.0, world["current_noise_a"])
        ir = ibus[1] + offs[1] + rn.gauss(0.0, world["current_noise_a"])
        bl = vbus[0] + rn.gauss(0.0, world["bus_noise_v"])
        br = vbus[1] + rn.gauss(0.0, world["bus_noise_v"])
        il = round(il / 0.0005) * 0.0005
        ir = round(ir / 0.0005) * 0.0005
        bl = round(bl / 0.00125) * 0.00125
        br = round(br / 0.00125) * 0.00125
        yaw_m = yaw + rn.gauss(0.0, world["yaw_noise_rad"])
        pitch_m = math.degrees(pitch) + rn.gauss(0.0, world["pitch_noise_deg"])
        rows.append("%.4f,%.5f,%.4f,%.5f,%.4f,%.6f,%.6f,%.5f,%.3f\n" % (
            t, bl, il, br, ir, cmd_l, cmd_r, yaw_m, pitch_m))
        if man is not None:
            man["e"][0] += bl * il * dt
            man["e"][1] += br * ir * dt
        yaw += w * dt
        t = len(rows) * dt

    def standstill(dur):
        n = int(round(dur / dt))
        for _ in range(n):
            emit(0.0, 0.0, None)

    standstill(plan["initial_s"])
    for idx, mspec in enumerate(plan["manoeuvres"]):
        ratio = mspec["ratio"]
        # A driven scenario (drive_scenario) sets these per manoeuvre; the turn sets do not.
        m_vc = mspec.get("v_c", vc)
        m_turn_rad = math.radians(mspec["turn_deg"]) if "turn_deg" in mspec else turn_rad
        m_straight_s = mspec.get("straight_s", world["straight_s"])
        v_in, v_out = side_speeds(m_vc, ratio, r_prime)
        if mspec.get("left", left):
            vl_c, vr_c = v_in, v_out
            inner = 0
        else:
            vl_c, vr_c = v_out, v_in
            inner = 1
        cmd_vec = (vl_c, vr_c)
        w_cmd = (vr_c - vl_c) / rv["Bs"]
        if ratio is None:
            t_nom = m_straight_s
        else:
            t_nom = m_turn_rad / abs(w_cmd)
        man = {"mu_mult": mspec["mu_mult"], "drag_c": None, "drag_b": None,
               "e": [0.0, 0.0], "t_on": 0.0, "inner_side": inner,
               "inner_drag": terrain_eff == "inner-drag" and ratio is not None,
               "sin_beta": [1.0] * 4}
        pitch, roll = slope_angles(yaw)
        p = body.loads(pitch, roll)
        s_extra = angular_slip_extra(effect, ratio) if terrain_eff == "angular-slip" else 0.0
        mux, muy = mux0 * mspec["mu_mult"], muy0 * mspec["mu_mult"]
        if s_extra > 0.0:
            # Eq 6.3: the yaw lags the command by s_extra more in this turn; the wheels lose
            # longitudinal grip so that the side ICRs move out to slip_track / (1 - s_extra)
            st = slip_track / (1.0 - s_extra)
            mux = muy / math.sqrt(anisotropy_for(st, body.B, body.L))
        man["mux"], man["muy"] = mux, muy
        if terrain_eff == "braked-inner" and ratio is not None and abs(ratio - 1.0) < 1e-12:
            man["drag_c"] = [effect["kappa"] * p[i] if body.wheels[i][2] == inner else 0.0
                             for i in range(4)]
        if sink is not None:
            sink.reset()
            man["drag_b"] = [0.0] * 4

        def resolve(guess):
            pitch_, roll_ = slope_angles(yaw)
            p_ = body.loads(pitch_, roll_)
            gx = -body.m * G0 * math.sin(pitch_)
            gy = -body.m * G0 * math.sin(roll_)
            if sink is not None:
                man["drag_b"] = [min(0.2 * p_[i], sink.bulldozing(i, man["sin_beta"][i]))
                                 for i in range(4)]
            sol = solve_twist(body, vl_c, vr_c, p_, mux, muy, gx, gy, man["drag_c"],
                              man["drag_b"], guess)
            return tuple(sol)

        guess = [(vl_c + vr_c) / 2.0, 0.0, (vr_c - vl_c) / slip_track * (1.0 - s_extra)]
        twist_ss = resolve(guess)
        dynamic = sink is not None or terrain_eff == "slope"
        yaw0 = yaw
        i0 = len(rows)
        n_max = int(max(5.0 * t_nom, 10.0) / dt)
        n_straight = int(round(m_straight_s / dt))
        n = 0
        next_solve = 0.2
        while True:
            if ratio is None:
                if n >= n_straight:
                    break
            else:
                if abs(yaw - yaw0) >= m_turn_rad or n >= n_max:
                    break
            emit(vl_c, vr_c, man)
            n += 1
            man["t_on"] = n * dt
            if dynamic and man["t_on"] >= next_solve:
                next_solve += 0.2
                twist_ss = resolve(list(twist_ss))
        i1 = len(rows)
        records.append({
            "run": plan["name"], "index": idx, "ratio": ratio,
            "key": ratio_key(ratio), "regime": regime_of(ratio, rv),
            "t_nom_s": t_nom, "duration_s": (i1 - i0) * dt,
            "e_side_j": man["e"][:],
        })
        standstill(mspec["pause_s"])
    diag = {"t_winding_end_c": [round(x, 2) for x in T],
            "v_bus_end_v": [round(x, 3) for x in vbus]}
    return rows, records, diag


HEADER = ("t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,"
          "cmd_left_mps,cmd_right_mps,yaw_rad,pitch_deg\n")


def simulate_dataset(world, effect, plans):
    dstate = DatasetState(world)
    out = {}
    for plan in plans:
        out[plan["name"]] = simulate_run(world, effect, plan, dstate)
    return out


# --------------------------------------------------------------------------------------------
# visibility against the twin
# --------------------------------------------------------------------------------------------

def visibility(sim, twin):
    def per_man(s):
        d = {}
        for name in ["run_0", "run_1", "run_2"]:
            for rec in s[name][1]:
                d[(name, rec["index"])] = rec
        return d

    a = per_man(sim)
    b = per_man(twin)
    diffs = []
    by_regime = {}
    for key, ra in a.items():
        rb = b[key]
        for s in range(2):
            da = ra["e_side_j"][s] / ra["t_nom_s"]
            db = rb["e_side_j"][s] / rb["t_nom_s"]
            diffs.append(da - db)
            by_regime.setdefault((ra["regime"], s), []).append(da - db)
    rms = math.sqrt(sum(x * x for x in diffs) / len(diffs))
    # repeat sigma: the twin's spread over repeats of the same manoeuvre and side
    groups = {}
    for key, rb in b.items():
        for s in range(2):
            groups.setdefault((rb["key"], s), []).append(rb["e_side_j"][s] / rb["t_nom_s"])
    vs = []
    for g in groups.values():
        if len(g) >= 2:
            m = sum(g) / len(g)
            vs.append(sum((x - m) ** 2 for x in g) / (len(g) - 1))
    sigma = math.sqrt(sum(vs) / len(vs)) if vs else 0.0
    thr = max(1.5, 3.0 * sigma)
    reg_means = {}
    for (reg, s), xs in by_regime.items():
        reg_means.setdefault(reg, [0.0, 0.0])
        reg_means[reg][s] = sum(xs) / len(xs)
    largest_reg, largest_val = None, 0.0
    for reg, (ml, mr) in reg_means.items():
        m = max(abs(ml), abs(mr))
        if m > largest_val:
            largest_reg, largest_val = reg, m
    # regime where the effect on power (both sides together) is largest
    tot = {reg: ml + mr for reg, (ml, mr) in reg_means.items()}
    power_reg = max(tot, key=lambda r: abs(tot[r])) if tot else None
    return {
        "twin_rms_w": rms,
        "repeat_sigma_w": sigma,
        "threshold_w": thr,
        "visible": rms > thr,
        "visible_local": largest_val > thr,
        "largest_regime": largest_reg,
        "largest_regime_diff_w": largest_val,
        "regime_mean_diff_w": {r: [round(v[0], 3), round(v[1], 3)] for r, v in reg_means.items()},
        "largest_power_regime": power_reg,
    }


# --------------------------------------------------------------------------------------------
# output
# --------------------------------------------------------------------------------------------

def write_dataset(path, world, effect, sim, vis):
    rv = ROVERS[world["rover"]]
    os.makedirs(path, exist_ok=True)
    with open(os.path.join(path, "rover.toml"), "w") as f:
        f.write("track_width_m = %.3f\nlength_m = %.2f\nwheel_radius_m = %.3f\n"
                "mass_kg = %.1f\nslip_track_m = %.2f\n" % (rv["B"], rv["L"], rv["r"], rv["m"],
                                                            rv["Bs"]))
    for name, (rows, _recs, _diag) in sim.items():
        with open(os.path.join(path, name + ".csv"), "w") as f:
            f.write(HEADER)
            f.write("".join(rows))
    if effect is None:
        truth = {"effect": "none", "regime": None, "visible": False, "visible_local": False,
                 "twin_rms_w": 0.0}
    else:
        if effect["id"] == "sinkage-bulldozing":
            regime = vis["largest_power_regime"]
        else:
            regime = FIXED_REGIME[effect["id"]]
        truth = {"effect": effect["id"], "regime": regime, "visible": vis["visible"],
                 "visible_local": vis["visible_local"], "twin_rms_w": round(vis["twin_rms_w"], 4)}
        for k in ["repeat_sigma_w", "threshold_w", "largest_regime", "largest_regime_diff_w",
                  "regime_mean_diff_w"]:
            v = vis[k]
            truth[k] = round(v, 4) if isinstance(v, float) else v
        truth["params"] = {k: (round(v, 5) if isinstance(v, float) else v)
                           for k, v in effect.items() if k != "id"}
    truth["rover"] = rv["name"]
    st = {}
    for k, v in world.items():
        if isinstance(v, float):
            st[k] = round(v, 5)
        elif isinstance(v, list):
            st[k] = [round(x, 5) if isinstance(x, float) else x for x in v]
        else:
            st[k] = v
    st["mu_y"] = round(world["mu_x"] * math.sqrt(anisotropy_for(
        world["terrain_slip_track_m"], rv["B"], rv["L"])), 5)
    truth["structure"] = st
    truth["runs"] = {name: sim[name][2] for name in sim}
    truth["manoeuvres"] = [
        {"run": r["run"], "R_over_R_prime": (None if r["ratio"] is None else round(r["ratio"], 4)),
         "regime": r["regime"], "duration_s": round(r["duration_s"], 3),
         "nominal_s": round(r["t_nom_s"], 3)}
        for name in ["run_0", "run_1", "run_2"] for r in sim[name][1]]
    with open(os.path.join(path, "truth.json"), "w") as f:
        json.dump(truth, f, indent=1)
        f.write("\n")


def generate(seed, out, count):
    os.makedirs(out, exist_ok=True)
    summary = []
    for cls in CLASSES:
        for k in range(count):
            t0 = time.time()
            world = draw_world(seed, cls, k)
            effect = draw_effect(seed, cls, k, world)
            plans = draw_plans(seed, cls, k, world, effect)
            sim = simulate_dataset(world, effect, plans)
            vis = None
            if effect is not None:
                twin = simulate_dataset(world, None, plans)
                vis = visibility(sim, twin)
            name = "%s-%s-%d" % (cls, seed, k)
            write_dataset(os.path.join(out, name), world, effect, sim, vis)
            summary.append((name, world["rover"], vis, time.time() - t0))
            sys.stderr.write("%-28s %-5s %s %5.1f s\n" % (
                name, world["rover"],
                ("rms %6.2f W thr %5.2f W visible %-5s local %-5s" % (
                    vis["twin_rms_w"], vis["threshold_w"], vis["visible"], vis["visible_local"]))
                if vis else "control" + " " * 40, time.time() - t0))
    return summary


def scenario_plan(seed, cls, k, world, name, path):
    """A plan driving the scenario file `path` (`host-tool diagnose --next-runs`) on the test
    terrain: its turns (r_over_r_prime, angle_deg, v_c_mps, direction) and straights
    (distance_m, speed_mps) in order, the list `repeats` times."""
    import tomllib
    with open(path, "rb") as f:
        sc = tomllib.load(f)
    rp = random.Random("worldE|%s|%s|%s|plan|%s" % (seed, cls, k, name))
    man = []
    for m in sc["manoeuvres"] * int(sc.get("repeats", 1)):
        spec = {"mu_mult": max(0.85, 1.0 + world["mu_sigma"] * rp.gauss(0.0, 1.0)),
                "pause_s": round(rp.uniform(1.5, 2.3), 2)}
        if m["kind"] == "turn":
            spec.update(ratio=float(m["r_over_r_prime"]), v_c=float(m.get("v_c_mps", 0.3)),
                        turn_deg=float(m.get("angle_deg", 90.0)),
                        left=m.get("direction", "left") == "left")
        elif m["kind"] == "straight":
            v = float(m.get("speed_mps", 0.3))
            spec.update(ratio=None, v_c=v, straight_s=float(m["distance_m"]) / v)
        else:
            sys.exit("%s: world E drives turns and straights, not %r" % (path, m["kind"]))
        man.append(spec)
    return {"name": name, "test": True, "initial_s": round(rp.uniform(3.0, 3.8), 2),
            "manoeuvres": man,
            "noise_seed": "worldE|%s|%s|%s|noise|%s" % (seed, cls, k, name)}


def drive_scenario(dataset, scenario):
    """Drives `scenario` in the world of `dataset` (a directory written by generate) as one
    more test run after the runs already there (the windings and the soil carry their history),
    and writes it as the next run_<n>.csv. Returns its path."""
    cls, seed, k = os.path.basename(os.path.normpath(dataset)).rsplit("-", 2)
    k = int(k)
    world = draw_world(seed, cls, k)
    effect = draw_effect(seed, cls, k, world)
    plans = draw_plans(seed, cls, k, world, effect)
    n = 3
    while os.path.exists(os.path.join(dataset, "run_%d.csv" % n)):
        plans.append(scenario_plan(seed, cls, k, world, "run_%d" % n,
                                   os.path.join(dataset, "next_%d.toml" % n)))
        n += 1
    name = "run_%d" % n
    with open(scenario, "rb") as src, open(os.path.join(dataset, "next_%d.toml" % n), "wb") as dst:
        dst.write(src.read())
    plans.append(scenario_plan(seed, cls, k, world, name, scenario))
    rows = simulate_dataset(world, effect, plans)[name][0]
    path = os.path.join(dataset, name + ".csv")
    with open(path, "w") as f:
        f.write(HEADER)
        f.write("".join(rows))
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int)
    ap.add_argument("--out")
    ap.add_argument("--count-per-class", type=int, default=1)
    ap.add_argument("--drive", metavar="SCENARIO.toml",
                    help="drive this scenario file in the world of --dataset as one more run")
    ap.add_argument("--dataset", metavar="DIR", help="with --drive: a dataset directory")
    args = ap.parse_args()
    if args.drive:
        if not args.dataset:
            ap.error("--drive needs --dataset")
        print(drive_scenario(args.dataset, args.drive))
        return
    if args.seed is None or args.out is None:
        ap.error("--seed and --out are required (or --drive with --dataset)")
    generate(args.seed, args.out, args.count_per_class)


if __name__ == "__main__":
    main()
