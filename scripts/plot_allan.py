#!/usr/bin/env python3
# plot_allan.py: publication-quality matplotlib version of analyze_bag's plot (DIR/allan.png and DIR/allan.svg).
"""Log-log Allan deviation per sensor (gyro row, accelerometer row if present) and axis (columns): measured oadev with
its confidence band, the fitted model, each supported IEEE term as a line labelled with its slope, the wavelet-split
curves when present and the model-check refit when it added effects.

analyze_bag draws the same figure itself; this script redraws it with matplotlib from DIR/allan.csv and
DIR/report.yaml, overwriting DIR/allan.png and DIR/allan.svg (e.g. at a higher --dpi for print).

usage: /usr/bin/python3 plot_allan.py DIR [--dpi D]
The figure is 5 in x 4 in per panel at --dpi (default 100): 3 axes x 1 sensor = 1500 x 400 px, 2 sensors = 1500 x 800.
"""
import csv
import math
import os
import sys

TERMS = [  # report key (gyro), report key (accel), slope label, AVAR basis per coefficient^2
    ("quantization", "velocity_quantization", "Q  slope -1", lambda t: 3.0 / t ** 2),
    ("angle_random_walk", "velocity_random_walk", "N  slope -1/2", lambda t: 1.0 / t),
    ("bias_instability", "bias_instability", "B  slope 0", lambda t: 2.0 * math.log(2.0) / math.pi),
    ("rate_random_walk", "acceleration_random_walk", "K  slope +1/2", lambda t: t / 3.0),
    ("rate_ramp", "acceleration_ramp", "R  slope +1", lambda t: t ** 2 / 2.0),
]
TERM_COLORS = ["tab:purple", "tab:green", "tab:olive", "tab:orange", "tab:red"]


def fail(msg, code=2):
    print("plot_allan: " + msg, file=sys.stderr)
    sys.exit(code)


def read_csv(path):
    rows = {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            rows.setdefault((r["axis"], r["deviation"]), []).append(r)
    return rows


def col(rows, name):
    out = []
    for r in rows:
        v = r.get(name, "")
        out.append(float(v) if v not in ("", None) else float("nan"))
    return out


def save(fig, out_dir, dpi):
    fig.savefig(os.path.join(out_dir, "allan.png"), dpi=dpi)
    fig.savefig(os.path.join(out_dir, "allan.svg"))


def main(argv):
    args = [a for a in argv[1:]]
    dpi = 100
    if "--dpi" in args:
        i = args.index("--dpi")
        try:
            dpi = int(args[i + 1])
        except (IndexError, ValueError):
            fail("--dpi needs an integer", 1)
        del args[i:i + 2]
    if len(args) != 1 or args[0] in ("-h", "--help"):
        print(__doc__)
        sys.exit(0 if args and args[0] in ("-h", "--help") else 1)
    out_dir = args[0]
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import yaml
    except ImportError as e:
        fail("python3-matplotlib / python3-yaml missing (%s): apt install python3-matplotlib python3-yaml" % e)
    csv_path, rep_path = os.path.join(out_dir, "allan.csv"), os.path.join(out_dir, "report.yaml")
    if not os.path.exists(csv_path):
        fail("no %s" % csv_path)
    data = read_csv(csv_path)
    report = {}
    if os.path.exists(rep_path):
        with open(rep_path) as f:
            report = yaml.safe_load(f) or {}

    gyro_axes = [a for a in (report.get("axes") or {}).keys()] or sorted(
        {a for (a, d) in data if not a.startswith("accel_")})
    sensors = [("gyro", gyro_axes, report.get("axes") or {}, "rad/s", 0)]
    acc = (report.get("accelerometer") or {}).get("axes") or {}
    acc_axes = [a for a in acc.keys() if ("accel_" + a, "oadev") in data]
    if acc_axes:
        sensors.append(("accelerometer", acc_axes, acc, "m/s^2", 1))
    ncols = max(len(s[1]) for s in sensors)
    fig, panels = plt.subplots(len(sensors), ncols, figsize=(5 * ncols, 4 * len(sensors)), dpi=dpi, squeeze=False)
    for row, (sensor, axes, node, unit, key_idx) in enumerate(sensors):
        for c in range(ncols):
            ax = panels[row][c]
            if c >= len(axes):
                ax.axis("off")
                continue
            name = axes[c]
            csv_axis = name if sensor == "gyro" else "accel_" + name
            pts = data.get((csv_axis, "oadev"), [])
            if not pts:
                ax.set_title("%s %s: no oadev" % (sensor, name))
                continue
            tau, dev = col(pts, "tau_s"), col(pts, "dev")
            lo, hi = col(pts, "dev_lo"), col(pts, "dev_hi")
            ax.fill_between(tau, lo, hi, color="tab:blue", alpha=0.2, lw=0, label="confidence interval")
            ax.loglog(tau, dev, "o", ms=3, color="tab:blue", label="oadev")
            model = col(pts, "model_dev")
            if any(m == m for m in model):
                ax.loglog(tau, model, "-", color="k", lw=1.5, label="fitted model")
            axis_node = node.get(name) or {}
            effects = ((axis_node.get("model_check") or {}).get("effects")) or []
            check = col(pts, "model_check_dev")
            if effects and any(m == m for m in check):
                ax.loglog(tau, check, "--", color="tab:brown", lw=1.2,
                          label="model check (+%s)" % ", ".join(str(e.get("type")) for e in effects))
            for dname, style, label in (("oadev_denoised", "s", "wavelet: denoised"),
                                        ("oadev_removed", "^", "wavelet: removed")):
                wp = data.get((csv_axis, dname))
                if wp:
                    ax.loglog(col(wp, "tau_s"), col(wp, "dev"), style, ms=2.5, alpha=0.7, label=label)
            ymin = min([v for v in lo + dev if v == v and v > 0] or [1e-12])
            for dname in ("oadev_removed", "oadev_denoised"):
                ymin = min([ymin] + [v for v in col(data.get((csv_axis, dname), []), "dev") if v == v and v > 0])
            ymax = max([v for v in hi + dev if v == v and v > 0] or [1.0])
            coefs = axis_node.get("coefficients") or {}
            for i, term in enumerate(TERMS):
                cnode = coefs.get(term[key_idx]) or {}
                v = cnode.get("value")
                if not cnode.get("supported") or not v:
                    continue
                line = [math.sqrt(float(v) ** 2 * term[3](t)) for t in tau]
                ax.loglog(tau, line, ":", color=TERM_COLORS[i], lw=1.2, label=term[2])
            ax.set_ylim(ymin / 2.0, ymax * 2.0)  # term lines far below the data do not squash the plot
            quality = axis_node.get("quality")
            verdict = {"bad": ", BAD FIT", "doubtful": ", doubtful"}.get(quality, "")
            ax.set_title("%s %s (%s%s)" % (sensor, name, axis_node.get("method", ""), verdict),
                         color="tab:red" if quality == "bad" else "black")
            ax.set_xlabel("tau [s]")
            ax.set_ylabel("Allan deviation [%s]" % unit)
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=6, loc="best")
    fig.tight_layout()
    save(fig, out_dir, dpi)
    plt.close(fig)


if __name__ == "__main__":
    main(sys.argv)
