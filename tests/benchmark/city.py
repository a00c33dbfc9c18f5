# SPDX-License-Identifier: MIT
"""The synthetic city of make_las.py: its constants, materials, random streams and the City,
which computes each point from its index (see make_las.py for what the city is and why the
file depends only on (points, seed, spacing))."""
import math

import numpy as np


# --- The file -----------------------------------------------------------------------------------
SCALE = 0.001
OFFSET = (500000.0, 4000000.0, 0.0)
ORIGIN = (1000.0, 1000.0)  # the square's corner, relative to OFFSET
HEADER_SIZE = 227
RECORD = np.dtype([("x", "<i4"), ("y", "<i4"), ("z", "<i4"), ("intensity", "<u2"),
                   ("flags", "u1"), ("classification", "u1"), ("scan_angle", "i1"),
                   ("user_data", "u1"), ("point_source_id", "<u2"), ("gps_time", "<f8"),
                   ("red", "<u2"), ("green", "<u2"), ("blue", "<u2")])
assert RECORD.itemsize == 34
EPSG = 32633  # WGS 84 / UTM zone 33N

# --- Random numbers -----------------------------------------------------------------------------
RANDOM_BLOCK = 1 << 16  # points whose uniforms come from one stream, seeded from (seed, block)
SCENE_STREAM, POINT_STREAM = 0x5CE4E, 0x9017
# The rows of a point's uniforms: those used by every point, then those used by some.
(U_ALONG, U_ACROSS, U_RANGE, U_BRIGHT, U_RED, U_GREEN, U_BLUE, U_INTENSITY, U_OUTLIER,
 U_CROWN, U_RETURNS, U_DEPTH, U_OUTLIER_DEPTH, U_RETURN) = range(14)
EVERY_POINT = U_OUTLIER + 1
UNIFORMS = 16  # a multiple of 4: four 16-bit uniforms from each 64-bit draw
OUTLIERS = 1e-4  # the fraction of low noise points (multipath)

# --- The scanner --------------------------------------------------------------------------------
T_MAX = 0.25  # tangent of the largest scan angle (14 degrees)
SWATH_MAX = 150.0  # widest swath on the ground, m
OVERLAP = 0.2  # of adjacent strips
MAIN_SHARE = 0.7  # of the pulses in the strips along Y; the rest in the cross strips along X
PULSE_PERIOD = 1.0 / 400e3  # s
TURN_TIME = 90.0  # s between strips
GPS_START = 340000000.0  # adjusted standard GPS time, s

# --- The city (lengths in m, block-local: 0 and P are the centre lines of the streets) ----------
P = 64.0  # street grid period: a block and half of each street around it
ROAD = 4.0  # the kerb: road closer to the centre line than this, sidewalk beyond
KERB = 0.12  # the road is this much lower than the sidewalk
WALK = 6.5  # the sidewalk ends here, the lots begin
MARK = 0.075  # half the width of the centre line
DASH = 6.0  # the centre line's period, half of it painted
BUILD_LO, BUILD_HI = 14.0, P - 14.0  # buildings stand inside this square of a block
LOT_GAP = 2.6  # half the least gap between the buildings of two lots
TOP_MAX = 20.0  # the tallest building (ridge)
INTERIOR = 8.9  # only points this far from a block's edge can hit a building
TREE_Q, TREE_Q_JITTER, TREE_R = 5.5, 0.3, (2.0, 3.0)  # crown centre from the edge, radius
TREE_SLOTS = (12.0, 28.0, 44.0)  # along each side of a block
CAR_SLOTS = (20.0, 36.0, 52.0)
SLOT_JITTER = 1.0
CAR_Q = 3.0
NOWHERE = -1e6  # where missing buildings, roof units, trees, cars are; minus: missing splits
# The ray of a pulse is shifted sideways by at most T_MAX * TOP_MAX at a roof: it must not reach
# another lot's building, nor the street trees, which are only tested on points nearer the edge.
assert T_MAX * TOP_MAX < min(2 * LOT_GAP, BUILD_LO - INTERIOR)
assert TREE_Q + TREE_Q_JITTER + TREE_R[1] < INTERIOR

# Materials: the user data of a point. Colour (8-bit), reflectance (intensity), colour noise.
MATERIALS = [
    ("asphalt", (72, 72, 76), 0.10, 10),
    ("road marking", (236, 236, 228), 0.62, 8),
    ("sidewalk", (172, 168, 160), 0.32, 8),
    ("grass", (86, 124, 52), 0.45, 16),
    ("roof tiles", (158, 66, 48), 0.28, 10),
    ("flat roof", (120, 120, 122), 0.22, 10),
    ("roof unit", (188, 190, 194), 0.55, 6),
    ("facade", (214, 196, 166), 0.38, 8),
    ("window", (42, 52, 64), 0.04, 6),
    ("vegetation", (60, 104, 44), 0.50, 20),
    ("car paint", (170, 172, 176), 0.30, 6),
    ("car glass", (30, 36, 44), 0.05, 5),
]
(ASPHALT, MARKING, SIDEWALK, GRASS, TILES, FLAT_ROOF, ROOF_UNIT, FACADE, WINDOW, VEGETATION,
 PAINT, CAR_GLASS) = range(len(MATERIALS))  # the code picks some by arithmetic on this order
MAT_RGB = np.array([m[1] for m in MATERIALS], np.float32).T.copy()
MAT_REFL = np.array([m[2] for m in MATERIALS], np.float32)
MAT_NOISE = np.array([m[3] for m in MATERIALS], np.float32)
TILE_COLOURS = [(158, 66, 48), (128, 58, 44), (92, 92, 98), (70, 74, 86), (176, 96, 60)]
FLAT_COLOURS = [(110, 110, 112), (150, 150, 146), (84, 84, 86), (190, 190, 186)]
FACADE_COLOURS = [(214, 196, 166), (230, 228, 220), (152, 76, 58), (218, 200, 128),
                  (150, 152, 156), (196, 170, 140)]
CAR_COLOURS = [(235, 235, 235), (28, 28, 30), (170, 172, 176), (160, 28, 30), (36, 64, 140),
               (80, 82, 86), (200, 180, 150)]
FACE_SHADE = np.array([0.90, 1.04, 0.84, 1.0], np.float32)  # -x, +x, -y, +y facing facades
ROOF_SHADE = np.array([1.0, 1.0, 0.92, 1.08], np.float32)  # flat; the two slopes of a gable
GROUND, CAR, HIGH_VEGETATION, BUILDING, LOW_NOISE = 2, 1, 5, 6, 7
WAVE = 6.0 * math.sqrt(3.0)  # scales h(1-h)(1-2h) to a sine-like wave in [-1, 1]


def wave(x):
    """A smooth (C1) periodic wave of period 1 in [-1, 1], like sin(2 pi x), from arithmetic."""
    h = x - np.floor(x)
    return WAVE * h * (1.0 - h) * (1.0 - 2.0 * h)


def frac(x):
    return x - np.floor(x)


def atan_degrees(t):
    """atan(t) in degrees for |t| < 0.3, by its series (arithmetic only)."""
    t2 = t * t
    return t * (1.0 + t2 * (-1.0 / 3 + t2 * (1.0 / 5 + t2 * (-1.0 / 7 + t2 / 9)))) * (180 / math.pi)


def uniform(bits):
    """16-bit random numbers as float32 in (0, 1)."""
    return (bits + np.float32(0.5)) * np.float32(1.0 / 65536)


def pick(rng, colours, n, jitter):
    """n colours from a palette, each channel jittered by +-jitter."""
    c = np.array(colours, np.float64)[rng.integers(0, len(colours), n)]
    return (c + rng.uniform(-jitter, jitter, (n, 3))).T


class City:
    """The scene and the scan pattern of a cloud of `points` points."""

    def __init__(self, points, seed, spacing):
        self.points, self.seed = points, seed
        rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, SCENE_STREAM])))
        self.L = L = spacing * math.sqrt(max(points, 1))
        self._plan_strips(points, L)

        # Ground: a gentle slope and a long, low undulation.
        self.z0 = rng.uniform(80.0, 160.0)
        self.slope = (rng.uniform(-0.006, 0.006), rng.uniform(-0.006, 0.006))
        self.bump = rng.uniform(0.3, 1.0)
        self.bump_freq = (1.0 / rng.uniform(150.0, 300.0), 1.0 / rng.uniform(150.0, 300.0))
        self.bump_phase = (rng.random(), rng.random())

        # Street grid: blocks of P, the grid shifted by (ox, oy).
        self.ox, self.oy = rng.uniform(0.0, P), rng.uniform(0.0, P)
        self.nbx = int((L + self.ox + 1.0) // P) + 1
        self.nby = int((L + self.oy + 1.0) // P) + 1
        self._plan_buildings(rng, self.nbx * self.nby)
        self._plan_trees_and_cars(rng, self.nbx * self.nby)

    def _plan_strips(self, points, L):
        ns = max(1, math.ceil(L / SWATH_MAX))  # strips per pass
        self.W = W = L / (ns * (1.0 - OVERLAP) + OVERLAP)  # swath
        self.hf = 0.5 * W / T_MAX  # flying height above the ground
        density = MAIN_SHARE * max(points, 1) / (ns * W * L)  # of one strip along Y
        self.M = M = max(1, round(W * math.sqrt(density)))  # pulses per scan line
        self.dc = W / M
        lines = -(-points // M)
        per_pass = [round(MAIN_SHARE * lines), 0]
        per_pass[1] = lines - per_pass[0]
        starts, cross, fwd, centre, da, t0 = [], [], [], [], [], []
        line, time_ = 0, GPS_START
        for p in (0, 1):
            for s in range(ns):
                k = per_pass[p] // ns + (s < per_pass[p] % ns)
                starts.append(line)
                cross.append(p == 1)
                fwd.append(s % 2 == 0)
                centre.append(0.5 * W + s * W * (1.0 - OVERLAP))
                da.append(L / max(k, 1))
                t0.append(time_)
                line += k
                time_ += k * M * PULSE_PERIOD + TURN_TIME
        self.line_start = np.array(starts, np.int64)
        self.strip_cross = np.array(cross)
        self.strip_fwd = np.array(fwd)
        # The scanner's right is +across for strips along +Y and for cross strips along -X.
        self.strip_right = self.strip_cross != self.strip_fwd
        self.strip_centre = np.array(centre)
        self.strip_da = np.array(da)
        self.strip_t0 = np.array(t0)
        self.cross_start = int(self.line_start[ns]) * M  # the first point of the cross strips

    def _plan_buildings(self, rng, nb):
        """Up to 2 x 2 lots a block, each with a building or none: a table of 4 nb lots."""
        split = rng.uniform(BUILD_LO + 0.35 * (BUILD_HI - BUILD_LO),
                            BUILD_LO + 0.65 * (BUILD_HI - BUILD_LO), (2, nb))
        split[rng.random((2, nb)) < 0.5] = -NOWHERE  # one lot across
        self.split_x, self.split_y = split
        lots = 4 * nb
        block = np.arange(lots) // 4
        lo, hi = np.empty((2, lots)), np.empty((2, lots))
        for axis, bit in ((0, 1), (1, 2)):
            second = (np.arange(lots) & bit) != 0
            sp = split[axis, block]
            one = sp == -NOWHERE
            lo[axis] = np.where(second, sp + LOT_GAP, BUILD_LO)
            hi[axis] = np.where(second | one, BUILD_HI, sp - LOT_GAP)
            hi[axis][second & one] = 0.0  # no second lot
        size = np.maximum(hi - lo, 0.0)
        exists = np.all(size >= 6.0, axis=0) & (rng.random(lots) < 0.85)
        width = np.maximum(np.minimum(6.0, size), size * rng.uniform(0.6, 1.0, (2, lots)))
        start = lo + (size - width) * rng.random((2, lots))
        width[:, ~exists] = 0.0
        start[:, ~exists] = NOWHERE
        x0, y0 = start
        x1, y1 = start + width
        floors = rng.integers(1, 6, lots)
        eave = 3.0 * floors + 0.6 + rng.uniform(-0.3, 0.3, lots)
        gable = rng.random(lots) < 0.5
        ridge_y = width[1] > width[0]  # the ridge runs along the longer side
        half = 0.5 * np.where(ridge_y, width[0], width[1])
        rise = np.where(gable, np.minimum(half * rng.uniform(0.45, 0.8, lots), TOP_MAX - eave), 0.0)
        top = eave + rise
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        bx, by = block % self.nbx, block // self.nbx
        base = self.ground_z(np.where(exists, bx * P + cx - self.ox, 0.0),
                             np.where(exists, by * P + cy - self.oy, 0.0))
        # A roof unit on most flat roofs.
        unit = ~gable & (rng.random(lots) < 0.7) & exists
        usize = rng.uniform(1.5, 4.0, (2, lots))
        ux0 = x0 + 1.0 + (width[0] - usize[0] - 2.0) * rng.random(lots)
        uy0 = y0 + 1.0 + (width[1] - usize[1] - 2.0) * rng.random(lots)
        unit &= np.all(width > usize + 2.0, axis=0)
        ux0[~unit] = NOWHERE
        uheight = rng.uniform(1.2, 2.5, lots)
        roof = np.where(gable, pick(rng, TILE_COLOURS, lots, 12), pick(rng, FLAT_COLOURS, lots, 8))
        facade = pick(rng, FACADE_COLOURS, lots, 10)
        window = rng.uniform(0.0, 3.0, lots)
        ux1, uy1 = ux0 + usize[0], uy0 + usize[1]
        # Across the scan lines and along them, for the strips along Y and for the cross strips.
        self.lots_main = np.vstack([x0, x1, y0, y1, top, eave, rise, base, ~ridge_y, ux0, ux1,
                                    uy0, uy1, uheight, gable, window])
        self.lots_cross = np.vstack([y0, y1, x0, x1, top, eave, rise, base, ridge_y, uy0, uy1,
                                     ux0, ux1, uheight, gable, window])
        self.roof_rgb = roof.astype(np.float32)
        self.facade_rgb = facade.astype(np.float32)

    def _plan_trees_and_cars(self, rng, nb):
        """Along each of the 4 sides of a block: a table of 4 nb x slots."""
        n = 4 * nb * len(TREE_SLOTS)
        p = np.tile(TREE_SLOTS, 4 * nb) + rng.uniform(-SLOT_JITTER, SLOT_JITTER, n)
        q = TREE_Q + rng.uniform(-TREE_Q_JITTER, TREE_Q_JITTER, n)
        r = np.where(rng.random(n) < 0.75, rng.uniform(*TREE_R, n), 1.0)
        p[r == 1.0] = NOWHERE  # no tree in this slot
        crown = rng.uniform(2.5, 4.0, n) + 0.9 * r  # crown centre above the ground
        tall = r * rng.uniform(1.0, 1.3, n)  # vertical semi-axis
        colour = np.where(rng.random(n) < 0.1, pick(rng, [(150, 110, 40)], n, 20),
                          pick(rng, [(60, 104, 44)], n, 18))
        self.trees = np.vstack([p, q, r, crown, tall])
        self.tree_rgb = colour.astype(np.float32)

        n = 4 * nb * len(CAR_SLOTS)
        p = np.tile(CAR_SLOTS, 4 * nb) + rng.uniform(-SLOT_JITTER, SLOT_JITTER, n)
        half_len = np.where(rng.random(n) < 0.55, rng.uniform(2.1, 2.45, n), 1e-6)
        p[half_len < 1] = NOWHERE
        half_w = rng.uniform(0.86, 0.95, n)
        heading = np.where(rng.random(n) < 0.5, 1.0, -1.0)
        colour = pick(rng, CAR_COLOURS, n, 6)
        self.cars = np.vstack([p, CAR_Q + rng.uniform(-0.1, 0.1, n), half_len, half_w, heading])
        self.car_rgb = colour.astype(np.float32)
        self.car_refl = (0.08 + 0.5 * colour.mean(axis=0) / 255).astype(np.float32)

    def ground_z(self, x, y):
        fx, fy = self.bump_freq
        px, py = self.bump_phase
        bump = wave((x * fx + px).astype(np.float32)) * wave((y * fy + py).astype(np.float32))
        return self.z0 + self.slope[0] * x + self.slope[1] * y + self.bump * bump

    def uniforms(self, a, b):
        """The random numbers of points [a, b): UNIFORMS rows of 16 bits (uniform() makes them
        floats), from the raw output of one PCG64 stream per RANDOM_BLOCK points (stable across
        numpy versions and byte orders)."""
        first, last = a // RANDOM_BLOCK, (b - 1) // RANDOM_BLOCK
        parts = []
        for q in range(first, last + 1):
            bits = np.random.PCG64(np.random.SeedSequence([self.seed, POINT_STREAM, q]))
            raw = bits.random_raw(RANDOM_BLOCK * UNIFORMS // 4).astype("<u8", copy=False)
            parts.append(raw.view("<u2").reshape(UNIFORMS, RANDOM_BLOCK))
        u = parts[0] if len(parts) == 1 else np.concatenate(parts, axis=1)
        off = a - first * RANDOM_BLOCK
        return u[:, off:off + b - a]

    def chunk(self, a, b):
        """The records of points [a, b) and their count by return number 1-5."""
        if a < self.cross_start < b:  # each piece scans along one axis
            first, second = self.chunk(a, self.cross_start), self.chunk(self.cross_start, b)
            return np.concatenate([first[0], second[0]]), first[1] + second[1]
        n = b - a
        bits = self.uniforms(a, b)
        u = uniform(bits[:EVERY_POINT])
        M = self.M
        cross = a >= self.cross_start

        # The pulse: its scan line (li, in this chunk's lines) and its place in the line (j).
        first_line = a // M
        lines = np.arange(first_line, (b - 1) // M + 1)
        strip = np.searchsorted(self.line_start, lines, side="right") - 1
        k = lines - self.line_start[strip]  # the line in its strip
        odd = k & 1
        da = self.strip_da[strip]
        sign = np.where(self.strip_fwd[strip], 1.0, -1.0)
        along0 = np.where(self.strip_fwd[strip], 0.0, self.L) + sign * k * da
        along_step, along_jitter = sign * da / M, sign * 0.5 * da
        right = self.strip_right[strip]
        right_sign = np.where(right, 1.0, -1.0).astype(np.float32)
        line_flags = ((odd == 0) == right).astype(np.uint8) << 6  # scanning to the right
        line_gps = self.strip_t0[strip] + k * M * PULSE_PERIOD
        line_source = (strip + 1).astype(np.uint16)
        centre = self.strip_centre[strip]

        i = np.arange(a, b, dtype=np.int64)
        line = i // M
        j = i - line * M
        li = line - first_line
        del i, line
        jr = j + np.take(odd, li) * (M - 1 - 2 * j)  # the sweep turns back on odd lines
        along = (np.take(along0, li) + (j + 0.5) * np.take(along_step, li)
                 + (u[U_ALONG] - 0.5) * np.take(along_jitter, li))
        c_rel = (jr + 0.5 + 0.5 * (u[U_ACROSS] - 0.5)) * self.dc - 0.5 * self.W
        across = np.take(centre, li) + c_rel
        del jr
        X, Y = (along, across) if cross else (across, along)
        t = c_rel / self.hf  # the ray at height h is t * h nearer the nadir (across)
        t32 = t.astype(np.float32)
        angle = np.rint(atan_degrees(t32 * np.take(right_sign, li)))
        flags = np.take(line_flags, li) | ((j == M - 1).astype(np.uint8) << 7)
        gps = np.take(line_gps, li) + j * PULSE_PERIOD
        source = np.take(line_source, li)
        del j, li, c_rel

        # The block, and the distance to its nearest edge.
        gx = X + self.ox
        bx = np.clip(np.floor(gx * (1.0 / P)), 0, self.nbx - 1)
        uu = gx - bx * P
        gy = Y + self.oy
        by = np.clip(np.floor(gy * (1.0 / P)), 0, self.nby - 1)
        vv = gy - by * P
        block = (by * self.nbx + bx).astype(np.int64)
        del gx, gy, bx, by
        qx = np.minimum(uu, P - uu)
        qy = np.minimum(vv, P - vv)
        q = np.minimum(qx, qy)

        z = self.ground_z(X, Y)
        mat = np.full(n, GRASS, np.uint8)
        cls = np.full(n, GROUND, np.uint8)
        ret = np.ones(n, np.uint8)
        nret = np.ones(n, np.uint8)
        tex = np.ones(n, np.float32)
        colours, reflectances = [], []  # objects' own: (points, table, rows)

        inner = q >= INTERIOR
        self._buildings(np.flatnonzero(inner), cross, u, X, Y, z, uu, vv, t, block, mat, cls,
                        tex, colours)
        self._streets(np.flatnonzero(~inner), bits, z, uu, vv, qx, qy, q, block, mat, cls, ret,
                      nret, tex, colours, reflectances)
        del uu, vv, qx, qy, q, block, inner

        # Low noise: a few points far below the surface.
        low = np.flatnonzero(u[U_OUTLIER] < OUTLIERS)
        z[low] -= 0.5 + 6.0 * uniform(bits[U_OUTLIER_DEPTH, low])
        cls[low] = LOW_NOISE
        z += (u[U_RANGE] - 0.5) * 0.03  # ranging noise

        # Colour and intensity.
        tex *= 1.0 + 0.07 * wave((X * 0.103).astype(np.float32)) * wave(
            (Y * 0.127).astype(np.float32))
        tex *= 0.94 + 0.12 * u[U_BRIGHT]
        tex *= 257.0  # 8-bit colours to 16 bits
        noise = np.take(MAT_NOISE, mat) * np.float32(257.0)
        rec = np.empty(n, RECORD)
        for c, name, row in ((0, "red", U_RED), (1, "green", U_GREEN), (2, "blue", U_BLUE)):
            v = np.take(MAT_RGB[c], mat)
            for idx, table, rows in colours:
                v[idx] = np.take(table[c], rows)
            v *= tex
            v += noise * (u[row] - 0.5)
            rec[name] = np.rint(np.minimum(np.maximum(v, 0.0, out=v), 65535.0, out=v), out=v)
        refl = np.take(MAT_REFL, mat)
        for idx, table, rows in reflectances:
            refl[idx] = np.take(table, rows)
        refl *= (0.85 + 0.3 * u[U_INTENSITY]) * (1.0 - 0.8 * t32 * t32)
        refl[ret > 1] *= 0.55
        refl *= 60000.0
        rec["intensity"] = np.rint(np.minimum(refl, 65535.0, out=refl), out=refl)

        rec["x"] = np.rint((X + ORIGIN[0]) * (1.0 / SCALE))
        rec["y"] = np.rint((Y + ORIGIN[1]) * (1.0 / SCALE))
        rec["z"] = np.rint(z * (1.0 / SCALE))
        rec["flags"] = ret | (nret << 3) | flags
        rec["classification"] = cls
        rec["scan_angle"] = angle
        rec["user_data"] = mat
        rec["point_source_id"] = source
        rec["gps_time"] = gps
        returns = np.bincount(ret, minlength=6)[1:6]
        return rec, returns

    def _buildings(self, ii, cross, u, X, Y, z, uu, vv, t, block, mat, cls, tex, colours):
        """Points far from the streets: a roof or a facade of the building of their lot, if the
        ray meets it, else grass (already set). In coordinates across the scan line (a) and along
        the flight (e)."""
        al, el = (vv, uu) if cross else (uu, vv)
        ai, ei, ti, bi = al[ii], el[ii], t[ii], block[ii]
        split_a, split_e = (self.split_y, self.split_x) if cross else (self.split_x, self.split_y)
        la = ai >= np.take(split_a, bi) + LOT_GAP * np.sign(ti)
        le = ei >= np.take(split_e, bi)
        lot = 4 * bi + (2 * la + le if cross else la + 2 * le)
        table = self.lots_cross if cross else self.lots_main
        a0, a1, e0, e1, top = np.take(table[:5], lot, axis=1)
        in_e = (ei >= e0) & (ei <= e1)
        ar = ai - ti * top  # where the ray is at the height of the top
        roof = in_e & (ar >= a0) & (ar <= a1)
        ahead = ti > 0
        face = a0 * ahead + a1 * ~ahead  # the facade that faces the scanner
        with np.errstate(divide="ignore", invalid="ignore"):
            h = (ai - face) / ti  # the height at which the ray crosses it
        wall = in_e & ~roof & (h >= 0) & (h < top)
        moved = Y if cross else X

        # Roofs; a gable roof slopes along e if its ridge runs across.
        r = np.flatnonzero(roof)
        ri = ii[r]
        eave, rise, base, ridge_across, ua0, ua1, ue0, ue1, uh, gable = np.take(
            table[5:15], lot[r], axis=1)
        rc = ridge_across > 0.5
        er, arr = ei[r], ar[r]
        slope = er * rc + arr * ~rc
        lo = e0[r] * rc + a0[r] * ~rc
        hi = e1[r] * rc + a1[r] * ~rc
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        off = np.abs(slope - mid)
        unit = (arr >= ua0) & (arr <= ua1) & (er >= ue0) & (er <= ue1)
        g = gable > 0.5
        moved[ri] -= ti[r] * top[r]
        z[ri] = base + eave + rise * (1.0 - off / half) + uh * unit
        mat[ri] = FLAT_ROOF - g + unit
        cls[ri] = BUILDING
        own = np.flatnonzero(~unit)
        colours.append((ri[own], self.roof_rgb, lot[r[own]]))
        rows = (frac(off * (1.0 / 0.32)) < 0.18) & g  # tile rows
        tex[ri] = np.take(ROOF_SHADE, 2 * g + (slope > mid)) * (1.0 - 0.22 * rows)

        # Facades, from the ground to the roof's edge above them, with windows.
        w = np.flatnonzero(wall)
        wi = ii[w]
        eave, rise, base, ridge_across, win = np.take(table[[5, 6, 7, 8, 15]], lot[w], axis=1)
        ew, e0w, e1w = ei[w], e0[w], e1[w]
        eh = 0.5 * (e1w - e0w)
        edge = eave + ridge_across * rise * (1.0 - np.abs(ew - (e0w + eh)) / eh)
        height = h[w] * (edge / top[w])
        moved[wi] += face[w] - ai[w] + (u[U_RANGE, wi] - 0.5) * 0.03
        z[wi] = base + height
        fa = frac((ew - e0w - win) * (1.0 / 3.0))
        fh = frac(height * (1.0 / 3.0))
        glass = ((fa >= 0.3) & (fa < 0.7) & (fh >= 0.3) & (fh < 0.75) & (height < eave - 0.4)
                 & (ew - e0w > 1.0) & (e1w - ew > 1.0))
        mat[wi] = FACADE + glass
        cls[wi] = BUILDING
        plaster = np.flatnonzero(~glass)
        colours.append((wi[plaster], self.facade_rgb, lot[w[plaster]]))
        tex[wi] = np.take(FACE_SHADE, 2 * cross + (ti[w] < 0))

    def _streets(self, oo, bits, z, uu, vv, qx, qy, q, block, mat, cls, ret, nret, tex, colours,
                 reflectances):
        """Points near a block's edge: a street tree, a parked car, or the street."""
        uo, vo, qo, bo = uu[oo], vv[oo], q[oo], block[oo]
        sx = qx[oo] <= qy[oo]  # nearest to the west or the east edge (0, 1), else south, north
        nx = ~sx
        side = 2 * nx + (sx & (uo > P - uo)) + (nx & (vo > P - vo))
        p = vo * sx + uo * nx  # along the nearest edge
        edge = 4 * bo + side
        ground = np.ones(len(oo), bool)

        # Street trees: blobs with up to 4 returns, the last on the ground.
        slot = np.clip(np.rint((p - TREE_SLOTS[0]) * (1.0 / (TREE_SLOTS[1] - TREE_SLOTS[0]))), 0,
                       len(TREE_SLOTS) - 1).astype(np.int64)
        tree = edge * len(TREE_SLOTS) + slot
        tp, tq, tr, crown, tall = np.take(self.trees, tree, axis=1)
        d2 = (p - tp) ** 2 + (qo - tq) ** 2
        rr = tr * (0.82 + 0.18 * uniform(bits[U_CROWN, oo]))
        hit = np.flatnonzero(d2 < rr * rr)
        ti = oo[hit]
        ur = uniform(bits[U_RETURNS, ti])
        n = 1 + (ur >= 0.25).astype(np.uint8) + (ur >= 0.6) + (ur >= 0.88)
        r = np.minimum(1 + (uniform(bits[U_RETURN, ti]) * n).astype(np.uint8), n)
        ret[ti], nret[ti] = r, n
        chord = np.sqrt(np.maximum(1.0 - d2[hit] / (rr[hit] * rr[hit]), 0.0)) * tall[hit]
        leaf = np.flatnonzero((r < n) | (n == 1))  # the last of several returns is the ground
        li, hl = ti[leaf], hit[leaf]
        depth = uniform(bits[U_DEPTH, li])
        first = r[leaf] == 1
        z[li] += crown[hl] + chord[leaf] * np.where(first, 0.85 + 0.15 * depth, 0.9 - 1.8 * depth)
        mat[li] = VEGETATION
        cls[li] = HIGH_VEGETATION
        colours.append((li, self.tree_rgb, tree[hl]))
        tex[li] = np.where(first, 0.8 + 0.35 * depth, 0.6)
        ground[hl] = False

        # Parked cars, beside the kerb between the trees.
        rest = np.flatnonzero(ground & (qo > CAR_Q - 1.0) & (qo < ROAD))
        slot = np.clip(np.rint((p[rest] - CAR_SLOTS[0]) * (1.0 / (CAR_SLOTS[1] - CAR_SLOTS[0]))),
                       0, len(CAR_SLOTS) - 1).astype(np.int64)
        car = edge[rest] * len(CAR_SLOTS) + slot
        cp, cq, hl, hw, heading = np.take(self.cars, car, axis=1)
        sl = (p[rest] - cp) / hl * heading  # -1 rear to +1 front
        dq = np.abs(qo[rest] - cq)
        on = np.flatnonzero((np.abs(sl) <= 1.0) & (dq <= hw))
        ci = oo[rest[on]]
        sl, dq, hw, car = sl[on], dq[on], hw[on], car[on]
        cabin = dq <= hw - 0.18
        hood = sl > 0.45
        shield = (sl > 0.15) & ~hood
        roof = (sl > -0.5) & (sl <= 0.15)
        rear = (sl > -0.72) & (sl <= -0.5)
        zc = np.where(hood, 0.95, 1.05)
        zc = np.where(shield & cabin, 0.95 + (0.45 - sl) * (0.5 / 0.3), zc)
        zc = np.where(roof & cabin, 1.45, zc)
        zc = np.where(rear & cabin, 1.45 - (-0.5 - sl) * (0.4 / 0.22), zc)
        dn = dq / hw
        dn2 = dn * dn
        zc *= 1.0 - 0.12 * dn2 * dn2  # rounded sides
        z[ci] += zc - KERB
        glass = cabin & (shield | rear)
        mat[ci] = PAINT + glass
        cls[ci] = CAR
        paint = np.flatnonzero(~glass)
        colours.append((ci[paint], self.car_rgb, car[paint]))
        reflectances.append((ci[paint], self.car_refl, car[paint]))
        tex[ci] = np.where(roof, 1.05, 1.0)
        ground[rest[on]] = False

        # The street: road (below the kerb), centre line, sidewalk with joints, grass.
        gi = np.flatnonzero(ground)
        go = oo[gi]
        qg, pg = qo[gi], p[gi]
        crossing = (qx[go] < WALK) & (qy[go] < WALK)
        road = qg < ROAD
        walk = (qg >= ROAD) & (qg < WALK)
        line = (qg < MARK) & ~crossing & (frac(pg * (1.0 / DASH)) < 0.5)
        mat[go] = GRASS - walk - 3 * road + line
        z[go] -= KERB * road
        joint = walk & ((frac(pg * (1.0 / 1.5)) < 0.03) | (frac(qg * (1.0 / 1.25)) < 0.04))
        tex[go] = 1.0 - 0.3 * joint
