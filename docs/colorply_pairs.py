#!/usr/bin/env python3
"""A real multispectral point-cloud pair with known ground truth (the identity), built from
arthurdjn/colorply's MicMac test data, for `ced eval` on extra per-point channels.

    /usr/bin/python3 docs/colorply_pairs.py OUT [--from DIR] [--check]

Needs numpy only (a minimal reader below handles the uncompressed 16-bit TIFFs). Reads the
files listed in FILES from arthurdjn/colorply at a pinned commit: from
DIR/arthurdjn/colorply/<path> when --from DIR is given, else downloaded once from
raw.githubusercontent.com to OUT/download/arthurdjn/colorply/<path> (the same layout, so a
folder filled by hand works as DIR). Without network, fill DIR from a clone:

    git -C CLONE show COMMIT:PATH > DIR/arthurdjn/colorply/PATH

The data: a Parrot Sequoia flight (four 1280x960 cameras: GRE ~550 nm, RED ~660 nm, REG
~735 nm, NIR ~790 nm), MicMac's dense cloud C3DC_MicMac_1bandeAllCampariGCP.ply (107,535
points, georeferenced metres, a grey channel) and MicMac's orientations
(Ori-1bande_All_CampariGCP: one Orientation-<image>.xml per image and band, one
AutoCal_...-<band>.xml per band).

The pair, on the same surface with different points and different images:
- the points are shuffled (numpy default_rng(SEED)) and split in halves: source = the first
  half, target = the second (each written in the cloud's stored order);
- the images are split by acquisition: the source sees SETS["source"], the target
  SETS["target"];
- each band value of a point is the mean, over the images of its side in which it lies in
  front of the camera and projects inside the image with a MARGIN px border, of the
  bilinearly interpolated raw DN (pixel centres at integer coordinates, as colorply's own
  rounding assumes). Occlusion is ignored: a point hidden behind a tree crown in some image
  still takes that image's DN, so bands are noisier at occlusion edges than true
  reflectances. A point that no image of its side sees in some band is dropped.

Writes OUT/colorply/ms_pair/source.ply and target.ply (binary: float x y z as stored, uchar
red green blue = MicMac's grey, float ms_green ms_red ms_rededge ms_nir = mean raw DN, not
rescaled, clipped at 65472 on a few dozen points; no coordinate offset: float32 at ~900 m
is ~60 um), transform.txt (the 4x4 identity, row-major) and OUT/pairs.csv.

MicMac's convention (eConvApero_DistM2C), found by testing candidates against the <Appuis>
(pixel <Im>, ground <Ter>) of every orientation's <Verif> block, which it reproduces to 1e-11
px (the script fails above 1 px): with the <CodageMatr> rows L1 L2 L3 as R and <Centre> C,
R maps camera to ground, so p = R^T (X - C); the point is in front when p_z > 0; the ideal
pixel is PP + F p_xy / p_z; distortion is applied ideal -> distorted (M2C): u = CDist + d (1
+ k1 r^2 + k2 r^4 + k3 r^6), d = ideal - CDist, r = |d|, k = <CoeffDist>. The other
candidates (R ground -> camera, -p_z, distortion inverted or left out) miss by 96-1924 px.
The TIFFs carry Orientation = 3 (rotated 180 degrees); MicMac, like this script, uses the
rows as stored: so sampled, a band's images agree with each other (r = 0.4-0.95 per image
pair) and with the cloud's grey (0.84-0.93 on REG); rotated they do not (|r| < 0.26).

--check re-reads the pair, recomputes the counts and, on a 20,000-point sample of the source,
each band's correlation between a source point and its nearest target point (and their
median distance), and compares them with pairs.csv. On 2026-12-07: 0.78-0.88 at 0.15 m
median; at the same points the two image sets agree to 0.94-0.96, DN ratio 0.99-1.01.

Licence: arthurdjn/colorply is MIT (Copyright (c) 2019 arthurdjn), data included; the flight
is the authors' own (a photogrammetry engineering project, per its README).
"""
import csv
import os
import re
import struct
import sys
import urllib.request

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # light on shared cores
import numpy as np  # noqa: E402

REPO = ("arthurdjn/colorply", "99b4c0edcea70827501c03a47216217d3e066f42", "MIT")
CLOUD = "test/data/C3DC_MicMac_1bandeAllCampariGCP.ply"
ORI = "test/data/calibration/Ori-1bande_All_CampariGCP"
STAMPS = {"0016": "082134", "0018": "082140", "0020": "082146", "0022": "082152", "0024": "082157"}
BANDS = [("GRE", "ms_green"), ("RED", "ms_red"), ("REG", "ms_rededge"), ("NIR", "ms_nir")]
SETS = {"source": ["0016", "0020", "0024"], "target": ["0018", "0022"]}
SEED, MARGIN, SAMPLE, MAX_APPUIS_PX = 59, 2, 20000, 1.0
SCENE, PAIR = "colorply", "ms_pair"


def image_path(stamp, band):
    return "test/data/images/%s/IMG_190716_%s_%s_%s.TIF" % (band, STAMPS[stamp], stamp, band)


def fetched(path, src, out):
    """The local path of PATH in REPO: under src when given, else downloaded once from
    raw.githubusercontent.com at the pinned commit to OUT/download."""
    if src:
        return os.path.join(src, REPO[0], path)
    cached = os.path.join(out, "download", REPO[0], path)
    if not os.path.exists(cached):
        os.makedirs(os.path.dirname(cached), exist_ok=True)
        url = "https://raw.githubusercontent.com/%s/%s/%s" % (REPO[0], REPO[1], path)
        with urllib.request.urlopen(url) as r, open(cached + ".part", "wb") as f:
            f.write(r.read())
        os.replace(cached + ".part", cached)  # no half-downloaded file under the final name
    return cached


def read_tif(path):
    """An uncompressed single-channel 16-bit TIFF's first image as a float64 array (rows as
    stored; the Orientation tag is ignored, as MicMac ignores it)."""
    b = open(path, "rb").read()
    bo = {b"II": "<", b"MM": ">"}[b[:2]]
    if struct.unpack(bo + "H", b[2:4])[0] != 42:
        raise ValueError("%s: not a classic TIFF" % path)
    ifd = struct.unpack(bo + "I", b[4:8])[0]
    tags = {}
    for k in range(struct.unpack(bo + "H", b[ifd : ifd + 2])[0]):
        tag, typ, count, raw = struct.unpack(bo + "HHI4s", b[ifd + 2 + 12 * k : ifd + 14 + 12 * k])
        if typ in (3, 4):  # SHORT, LONG: inline when they fit in 4 bytes, else at an offset
            fmt = "H" if typ == 3 else "I"
            size = struct.calcsize(fmt) * count
            data = raw[:size] if size <= 4 else b[struct.unpack(bo + "I", raw)[0] :][:size]
            tags[tag] = struct.unpack(bo + fmt * count, data)
    w, h = tags[256][0], tags[257][0]
    if tags.get(258, (1,))[0] != 16 or tags.get(259, (1,))[0] != 1 or tags.get(277, (1,))[0] != 1:
        raise ValueError("%s: only uncompressed single-channel 16-bit TIFFs are read" % path)
    strips = b"".join(b[o : o + n] for o, n in zip(tags[273], tags[279]))
    return np.frombuffer(strips, bo + "u2", w * h).reshape(h, w).astype(np.float64)


PLY_TYPES = {"float": "f4", "double": "f8", "uchar": "u1", "int": "i4", "uint": "u4", "short": "i2", "ushort": "u2"}


def read_ply(path):
    """A binary little-endian PLY's vertices as a numpy structured array (scalar properties)."""
    b = open(path, "rb").read()
    end = b.index(b"end_header\n") + len(b"end_header\n")
    lines = b[:end].decode("ascii").splitlines()
    if "format binary_little_endian 1.0" not in lines:
        raise ValueError("%s: not a binary little-endian PLY" % path)
    fields, n, element = [], None, None
    for words in (line.split() for line in lines):
        if words[0] == "element":
            element = words[1]
            if element != "vertex" and n is None and int(words[2]) > 0:
                raise ValueError("%s: data before the vertices" % path)
            n = int(words[2]) if element == "vertex" else n
        elif words[0] == "property" and element == "vertex":
            fields.append((words[2], "<" + PLY_TYPES[words[1]]))
    return np.frombuffer(b, np.dtype(fields), n, end)


def xml_numbers(text, tag):
    return [np.array(m.split(), float) for m in re.findall(r"<%s>([^<]*)</%s>" % (tag, tag), text)]


class Camera:
    """One image's MicMac conic orientation and its band's calibration (see the docstring)."""

    def __init__(self, orientation, src, out):
        x = open(fetched(orientation, src, out)).read()
        if "<KnownConv>eConvApero_DistM2C</KnownConv>" not in x or "<TypeProj>eProjStenope" not in x:
            raise ValueError("%s: not a DistM2C pinhole orientation" % orientation)
        self.centre = xml_numbers(x, "Centre")[0]
        self.rot = np.array([xml_numbers(x, "L%d" % i)[0] for i in (1, 2, 3)])  # camera -> ground
        calib = re.search(r"<FileInterne>([^<]*)</FileInterne>", x).group(1)
        c = open(fetched(ORI + "/" + os.path.basename(calib), src, out)).read()
        self.pp, self.f = xml_numbers(c, "PP")[0], xml_numbers(c, "F")[0][0]
        self.size, self.cdist = xml_numbers(c, "SzIm")[0], xml_numbers(c, "CDist")[0]
        self.k = np.concatenate(xml_numbers(c, "CoeffDist"))
        self.im, self.ter = np.array(xml_numbers(x, "Im")), np.array(xml_numbers(x, "Ter"))

    def project(self, xyz):
        """(pixels N x 2, in front N bools) of ground points xyz (N x 3)."""
        p = (np.asarray(xyz, np.float64) - self.centre) @ self.rot  # R^T (X - C), row-wise
        ideal = self.pp + self.f * p[:, :2] / p[:, 2:3]
        d = ideal - self.cdist
        r2 = (d * d).sum(1, keepdims=True)
        return self.cdist + d * (1 + sum(k * r2 ** (i + 1) for i, k in enumerate(self.k))), p[:, 2] > 0

    def appuis_error(self):
        """The largest distance (px) between an <Appuis>'s <Im> and its projected <Ter>."""
        uv, front = self.project(self.ter)
        return np.inf if not front.all() else float(np.linalg.norm(uv - self.im, axis=1).max())


def bilinear(img, uv):
    """img at the pixels uv (pixel centres at integers); NaN outside the MARGIN px border."""
    h, w = img.shape
    inside = (uv[:, 0] >= MARGIN) & (uv[:, 0] <= w - 1 - MARGIN) & (uv[:, 1] >= MARGIN) & (uv[:, 1] <= h - 1 - MARGIN)
    x, y = np.clip(uv[:, 0], 0, w - 2), np.clip(uv[:, 1], 0, h - 2)
    i, j = x.astype(int), y.astype(int)
    fx, fy = x - i, y - j
    v = (img[j, i] * (1 - fx) + img[j, i + 1] * fx) * (1 - fy) + (img[j + 1, i] * (1 - fx) + img[j + 1, i + 1] * fx) * fy
    return np.where(inside, v, np.nan)


def band_means(xyz, stamps, band, cameras, src, out):
    """Per point, the mean DN of band over the images stamps that see it (NaN where none)."""
    total, seen = np.zeros(len(xyz)), np.zeros(len(xyz))
    for s in stamps:
        uv, front = cameras[(s, band)].project(xyz)
        v = bilinear(read_tif(fetched(image_path(s, band), src, out)), uv)
        ok = front & np.isfinite(v)
        total[ok] += v[ok]
        seen += ok
    return np.where(seen > 0, total / np.maximum(seen, 1), np.nan)


def write_ply(path, xyz, grey, bands):
    names = list("xyz") + ["red", "green", "blue"] + [n for _, n in BANDS]
    types = ["<f4"] * 3 + ["u1"] * 3 + ["<f4"] * len(BANDS)
    rec = np.empty(len(xyz), np.dtype(list(zip(names, types))))
    for name, column in zip(names, np.hstack([xyz, grey, bands]).T):  # exact: float32 and uchar fit float64
        rec[name] = column
    props = "".join("property %s %s\n" % ("uchar" if t == "u1" else "float", n) for n, t in zip(names, types))
    header = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n%send_header\n" % (len(rec), props)
    with open(path, "wb") as f:
        f.write(header.encode() + rec.tobytes())


def build(out, src):
    """Writes the pair; returns its row of pairs.csv (without the measures)."""
    cameras, worst = {}, 0.0
    for s in STAMPS:
        for band, _ in BANDS:
            name = os.path.basename(image_path(s, band))
            cameras[(s, band)] = cam = Camera("%s/Orientation-%s.xml" % (ORI, name), src, out)
            e = cam.appuis_error()
            print("%s: %3d Appuis reprojected, max error %.2e px" % (name, len(cam.ter), e))
            if not e < MAX_APPUIS_PX:
                sys.exit("%s: Appuis error %.3g px above %g px: projection is wrong" % (name, e, MAX_APPUIS_PX))
            worst = max(worst, e)
    cloud = read_ply(fetched(CLOUD, src, out))
    xyz = np.stack([cloud[a] for a in "xyz"], 1)  # float32 as stored: written back unchanged
    grey = np.stack([cloud[a] for a in ("red", "green", "blue")], 1)
    order = np.random.default_rng(SEED).permutation(len(cloud))
    halves = {"source": np.sort(order[: len(cloud) // 2]), "target": np.sort(order[len(cloud) // 2 :])}
    d = os.path.join(out, SCENE, PAIR)
    os.makedirs(d, exist_ok=True)
    row = {"scene": SCENE, "pair": PAIR, "split": "report", "kind": "multispectral photogrammetry",
           "bands": " ".join("%s=%s" % (n, b) for b, n in BANDS), "appuis_max_px": "%.2e" % worst}
    for side, idx in halves.items():
        bands = np.stack([band_means(xyz[idx], SETS[side], b, cameras, src, out) for b, _ in BANDS], 1)
        keep = np.isfinite(bands).all(1)
        print("%s: %d of %d points seen in every band by images %s; %d dropped" % (
            side, keep.sum(), len(idx), "+".join(SETS[side]), (~keep).sum()))
        write_ply(os.path.join(d, side + ".ply"), xyz[idx][keep], grey[idx][keep], bands[keep])
        row.update({side + "_dropped": int((~keep).sum()), side + "_images": "+".join(SETS[side])})
    np.savetxt(os.path.join(d, "transform.txt"), np.eye(4), fmt="%.10f")
    row["source"] = "%s@%s:%s + %s/ + test/data/images/{%s}/ (%d TIFs)" % (
        REPO[0], REPO[1][:12], CLOUD, ORI, ",".join(b for b, _ in BANDS), len(cameras))
    row["licence"] = "%s (%s, Copyright (c) 2019 arthurdjn)" % (REPO[0], REPO[2])
    return row


def nearest(queries, points, chunk=200):
    """Index of and distance to the nearest of points for each query (chunked brute force)."""
    mean = points.mean(0)
    q, p = queries - mean, points - mean
    pp = (p * p).sum(1)
    idx = np.empty(len(q), int)
    for a in range(0, len(q), chunk):
        idx[a : a + chunk] = np.argmin(pp - 2 * q[a : a + chunk] @ p.T, axis=1)
    return idx, np.linalg.norm(q - p[idx], axis=1)


COLUMNS = ["scene", "pair", "split", "kind", "source_points", "target_points", "source_dropped", "target_dropped",
           "bands", "source_images", "target_images", "appuis_max_px", "nn_median_m"] + \
          ["corr_" + n for _, n in BANDS] + ["source", "licence"]


def measured(out, verbose=False):
    """Counts, and per band the source/target correlation at nearest-neighbour pairs."""
    d = os.path.join(out, SCENE, PAIR)
    s, t = read_ply(os.path.join(d, "source.ply")), read_ply(os.path.join(d, "target.ply"))
    if not np.array_equal(np.loadtxt(os.path.join(d, "transform.txt")), np.eye(4)):
        raise ValueError("%s: transform.txt is not the identity" % d)
    pos = lambda c: np.stack([c[a] for a in "xyz"], 1).astype(np.float64)  # noqa: E731
    pick = np.random.default_rng(SEED).choice(len(s), min(SAMPLE, len(s)), replace=False)
    idx, dist = nearest(pos(s)[pick], pos(t))
    m = {"source_points": len(s), "target_points": len(t), "nn_median_m": "%.4f" % np.median(dist)}
    for b, n in BANDS:
        m["corr_" + n] = "%.4f" % np.corrcoef(s[n][pick], t[n][idx])[0, 1]
        if verbose:
            print("%-11s %-4s source %7.1f..%7.1f target %7.1f..%7.1f  nn correlation %s" % (
                n, b, s[n].min(), s[n].max(), t[n].min(), t[n].max(), m["corr_" + n]))
    if verbose:
        for side, c in (("source", s), ("target", t)):
            ndvi = (c["ms_nir"] - c["ms_red"]) / (c["ms_nir"] + c["ms_red"])
            print("%s NDVI (raw DN) %.3f..%.3f, median %.3f" % (side, ndvi.min(), ndvi.max(), np.median(ndvi)))
        print("nearest target point of %d source points: median %s m" % (len(pick), m["nn_median_m"]))
    return m


def check(out):
    """Recomputes the measures and compares them with pairs.csv; returns the number of differences."""
    with open(os.path.join(out, "pairs.csv")) as f:
        row = next(csv.DictReader(f))
    m = measured(out)
    bad = [k for k, v in m.items() if abs(float(v) - float(row[k])) > 1e-3]
    print("%s/%s: %s" % (SCENE, PAIR, "ok" if not bad else "DIFFERS from pairs.csv in " + ", ".join(bad)))
    return len(bad)


def main(argv):
    import argparse

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("out", help="folder for the pair and pairs.csv")
    p.add_argument("--from", dest="src", help="a folder with the sources as <owner>/<repo>/<path> (default: download)")
    p.add_argument("--check", action="store_true", help="recompute counts and nearest-neighbour band correlations")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    row = build(a.out, a.src)
    row.update(measured(a.out, verbose=True))
    with open(os.path.join(a.out, "pairs.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerow(row)
    print("wrote %s" % os.path.join(a.out, "pairs.csv"))
    if a.check and check(a.out):
        sys.exit(1)


if __name__ == "__main__":
    main(sys.argv[1:])
