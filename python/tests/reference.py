"""A float64, pure-Python reference of the law (docs/LAW.md, the specification of
controller-core) on a scenario with the Example 1 plant: the speed reference for host-sim (a
benchmark) and a cross-check of the f32 controller's figures (test_reference.py).

Graph, leader, plant and fault windows are read from the scenario file; the controller is the
predefined-time scheme with the hysteresis quantizer. Every step follows LAW §5-§6: consensus
error (10), backstepping (15)-(19), command (28), quantizer (2), adaptive laws (20)-(22) by forward
Euler, Levant's differentiator; the plant by RK4 with substeps, commands held.

    python3 reference.py ../../scenarios/example1.toml   # prints the summary figures and the time
"""

import math
import sys
import time

try:
    import tomllib
except ImportError:  # Python < 3.11
    tomllib = None


def sign(x):
    return (x > 0) - (x < 0)


def gains(c):
    z, n = c["zeta"], 2
    f = 2 ** (1 + z / 2)
    theta = min(
        n ** (-z / 2),
        f * c["p"] ** (z / 2) * (1 + z) / (2 + z),
        f * c["eta"] ** (z / 2) * (1 + z) / (2 + z),
        f * c["tau"] ** (z / 2) * (1 + 2 * z) / (2 + 2 * z),
    )
    c2 = math.pi / (z * c["ts"])
    c1 = math.pi / (theta * z * c["ts"])
    return c1, c2, 0.5 ** (1 + z / 2) * c1, 0.5 ** (1 - z / 2) * c2


def mtn(xs):
    """‖Φ‖² of the order-2 Taylor network: h1 + h2 of the squares."""
    z = [x * x for x in xs]
    h1 = sum(z)
    h2 = sum(z[a] * z[b] for a in range(len(z)) for b in range(a, len(z)))
    return h1 + h2


def smooth(x, w):
    return 0.0 if x == 0 and w == 0 else x / math.hypot(x, w)


class Quantizer:
    """Eq. (2), closed form; direction from successive commands."""

    def __init__(self, rho, u_min):
        self.rho, self.u_min = rho, u_min
        self.delta = (1 - rho) / (1 + rho)
        self.prev_u, self.out = 0.0, 0.0

    def level(self, a):
        c = max(1, math.ceil(math.log(a / self.u_min) / math.log(1 / self.rho)))
        return self.u_min * self.rho ** (1 - c)

    def __call__(self, u):
        d, a, dl = sign(u - self.prev_u), abs(u), self.delta
        self.prev_u = u
        if d == 0:
            return self.out
        if d < 0:
            if a <= self.u_min / (1 + dl):
                q = 0.0
            else:
                uc = self.level(a * (1 + dl))
                q = uc if a <= uc else uc * (1 + dl)
        elif a <= self.u_min:
            q = 0.0
        else:
            uc = self.level(a)
            q = uc if a <= uc / (1 - dl) else uc * (1 + dl)
        self.out = math.copysign(q, u) if q else 0.0
        return self.out


class Agent:
    def __init__(self, c, q, neighbours, pinned, gains_):
        self.c, self.nb, self.r = c, neighbours, 1 if pinned else 0
        self.S = len(neighbours)
        self.A = self.S + self.r
        self.c1, self.c2, self.k1, self.k2 = gains_
        self.mu, self.xi, self.lam = c["mu0"], c["xi0"], c["lambda0"]
        self.chi = None
        self.varpi = c["varpi0"]
        self.q = [Quantizer(q["rho"], q["u_min"]) for _ in range(2)]

    def step(self, x, y, yd, h):
        c, z = self.c, self.c["zeta"]
        k1, k2 = self.k1, self.k2
        MN = lambda e: sign(e) * (k1 * abs(e) ** (1 + z) + k2 * abs(e) ** (1 - z))
        yi = x[0]
        e1 = sum(yi - y[k] for k in self.nb) + self.r * (yi - yd)
        a1, a2 = c["a_check"]
        phi1 = mtn([yi] + [y[k] for k in self.nb])
        b1 = MN(e1) + self.mu * e1 * phi1 / (2 * a1 * a1) + (1 + self.A + self.S) / 2 * e1
        alpha = -(1 / (self.A * c["phi_low"][0])) * b1 * smooth(e1 * b1, self.varpi)
        if self.chi is None:
            self.chi = [alpha, 0.0]
        e2 = x[1] - alpha
        phi2 = mtn(x)
        b2 = (
            MN(e2)
            + self.mu * e2 * phi2 / (2 * a2 * a2)
            + e2
            + sign(e2) * (c["eps_bar"][0] + self.A * c["phi_up"][0] * abs(e1))
            - self.chi[1]
            + self.xi * math.tanh(e2 / c["gamma"])
        )
        lb = self.lam * b2
        delta = self.q[0].delta
        u = -(1 / (1 - delta)) * lb * smooth(e2 * lb, self.varpi)
        q = [self.q[0](u), self.q[1](u)]
        c1, c2 = self.c1, self.c2
        dmu = c["p"] / (2 * a1 * a1) * e1 * e1 * phi1 + c["p"] / (2 * a2 * a2) * e2 * e2 * phi2
        dmu -= c1 * self.mu ** (1 + z) + c2 * self.mu
        dxi = c["eta"] * abs(e2 * math.tanh(e2 / c["gamma"])) - c1 * self.xi ** (1 + z) - c2 * self.xi
        dlam = c["tau"] * abs(e2 * b2) - c1 * self.lam ** (1 + 2 * z) - c2 * self.lam
        self.mu = max(0.0, self.mu + h * dmu)
        self.xi = max(0.0, self.xi + h * dxi)
        self.lam = max(0.0, self.lam + h * dlam)
        d = self.chi[0] - alpha
        self.chi = [
            self.chi[0] + h * (-c["diff_l1"] * math.sqrt(abs(d)) * sign(d) + self.chi[1]),
            self.chi[1] + h * (-c["diff_l2"] * sign(d)),
        ]
        self.varpi = max(self.varpi * math.exp(-c["varpi_decay"] * h), c["varpi_min"])
        return [u, u], q


def in_window(rule, t):
    if t < rule["start"]:
        return False
    return (t - rule["start"]) % rule["period"] < rule["length"]


def applied(rules, q, t):
    """Actuator outputs after the faults (eq. 3) at time t."""
    out = list(q)
    for r in rules:
        l = r["actuator"] - 1
        if in_window(r, t):
            if r["kind"] == "partial":
                out[l] = r["gain"] * q[l]
            else:
                out[l] = r["bias"] + r["amplitude"] * math.sin(r["omega"] * t)
    return out


def deriv(x, a, t):
    x1, x2 = x
    return (x2 + 0.8 * x1 ** 3, a[0] + a[1] - 2 * x1 * x1 + x2 ** 3 + math.cos(t))


def run(s):
    sim, ctl, qz, ld = s["simulation"], s["controller"], s["quantizer"], s["leader"]
    rules = s["faults"]["rule"] if s["faults"].get("enabled", True) else []
    h, sub = sim["h"], sim["substeps"]
    samples = round(sim["t_end"] / h)
    g = gains(ctl)
    pinned = [i + 1 in s["graph"]["pinned"] for i in range(len(s["graph"]["neighbours"]))]
    agents = [Agent(ctl, qz, [k - 1 for k in nb], p, g) for nb, p in zip(s["graph"]["neighbours"], pinned)]
    xs = [list(x) for x in s["plant"]["x0"]]
    yd_of = lambda t: ld["amplitude"] * math.sin(ld["omega"] * t + ld["phase"]) + ld["offset"]
    worst_after = 0.0
    two_ts = 2 * ctl["ts"]
    for k in range(samples):
        t = k * h
        yd = yd_of(t)
        y = [x[0] for x in xs]
        if t >= two_ts:
            worst_after = max(worst_after, max(abs(v - yd) for v in y))
        qs = [a.step(x, y, yd, h)[1] for a, x in zip(agents, xs)]
        dt = h / sub
        for i, x in enumerate(xs):
            q = qs[i]
            for j in range(sub):
                t0 = t + j * dt
                k1_ = deriv(x, applied(rules, q, t0), t0)
                xa = [x[0] + dt / 2 * k1_[0], x[1] + dt / 2 * k1_[1]]
                k2_ = deriv(xa, applied(rules, q, t0 + dt / 2), t0 + dt / 2)
                xb = [x[0] + dt / 2 * k2_[0], x[1] + dt / 2 * k2_[1]]
                k3_ = deriv(xb, applied(rules, q, t0 + dt / 2), t0 + dt / 2)
                xc = [x[0] + dt * k3_[0], x[1] + dt * k3_[1]]
                k4_ = deriv(xc, applied(rules, q, t0 + dt), t0 + dt)
                x = [x[m] + dt / 6 * (k1_[m] + 2 * k2_[m] + 2 * k3_[m] + k4_[m]) for m in range(2)]
            xs[i] = x
    return {
        "c1": g[0],
        "c2": g[1],
        "max_error_after_predefined_time": worst_after,
        "final_mu": [a.mu for a in agents],
        "final_lambda": [a.lam for a in agents],
    }


def load(path):
    with open(path, "rb") as f:
        return tomllib.load(f)


if __name__ == "__main__":
    t0 = time.perf_counter()
    result = run(load(sys.argv[1]))
    print(result)
    print(f"{time.perf_counter() - t0:.2f} s")
