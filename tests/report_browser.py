#!/usr/bin/env python3
"""The HTML reports in a browser (ctest label `browser`; docs/design.md, "HTML reports").

Runs each command with --csv and --report on small scenes: `analyze` on a
2-D scene (the double pendulum, with --energy), a 3-D one (the 6x6x6
lattice) and one with complex shapes (Ziegler's column with dampers); `sweep` of a rotating frame (bead on a spinning hoop: Campbell
diagram), of a follower load (Ziegler's column: first order), with
--extrapolate (hanging chain) and over two parameters (a stability map);
`amplitude`, `simulate` (with more samples than the page draws) and
`equilibria` (the double pendulum). Opens each page in headless Chromium
from a file:// URL with the network disabled (host names resolve to
nothing, and the proxy is a closed local port), lets its scripts run for
virtual time, and asserts on the rendered DOM: the status line the page's
script fills says no script error, the expected number of plots (and
animated views with some frames drawn); every table that shows a CSV has
the CSV's header and fields, to the last digit (data-v), and numbers shown
within half a unit of their 6th digit.
Usage: report_browser.py MODAL SOURCE_DIR WORK_DIR
"""
import csv, html.parser, os, shutil, subprocess, sys

modal, source, work = sys.argv[1:4]
os.makedirs(work, exist_ok=True)
chromium = shutil.which("chromium") or shutil.which("chromium-browser")
if not chromium:
    sys.exit("chromium is not installed (scripts/setup-debian.sh installs it)")
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL:", message)


class Page(html.parser.HTMLParser):
    """The status attributes and every table with an id: header and cells (data-v, text)."""

    def __init__(self):
        super().__init__()
        self.status, self.tables, self.table, self.cell, self.header = {}, {}, None, None, None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id") == "report-status":
            self.status = a
        if tag == "table" and a.get("id"):
            self.table = self.tables.setdefault(a["id"], {"header": [], "rows": []})
        if self.table is not None and tag == "tr":
            self.table["rows"].append([])
        if self.table is not None and tag == "th":
            self.header = [""]
            self.table["header"].append(self.header)
        if self.table is not None and tag == "td":
            self.cell = [a.get("data-v"), ""]
            self.table["rows"][-1].append(self.cell)

    def handle_endtag(self, tag):
        if tag == "table":
            self.table = None
        if tag == "td":
            self.cell = None
        if tag == "th":
            self.header = None

    def handle_data(self, data):
        if self.cell is not None:
            self.cell[1] += data
        if self.header is not None:
            self.header[0] += data


def render(name, page, budget=500):
    """The page's DOM after its scripts ran (for `budget` ms of virtual time), parsed."""
    dom = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--user-data-dir=" + page + "-profile",
                          "--host-resolver-rules=MAP * ~NOTFOUND", "--proxy-server=127.0.0.1:9",
                          f"--virtual-time-budget={budget}", "--dump-dom", "file://" + os.path.abspath(page)],
                         check=True, capture_output=True, text=True, timeout=120).stdout
    p = Page()
    p.feed(dom)
    return p


def check_status(name, p, plots, views=0):
    s = p.status
    check(s.get("data-done") == "1", f"{name}: the page's script did not finish (status {s})")
    check(s.get("data-errors") == "0", f"{name}: script errors: {s}")
    check(s.get("data-plots") == str(plots), f"{name}: {s.get('data-plots')} plots, expected {plots}")
    check(s.get("data-views") == str(views), f"{name}: {s.get('data-views')} animated views, expected {views}")
    if views:
        check(int(s.get("data-frames", "0")) > 2 * views, f"{name}: too few frames drawn ({s.get('data-frames')})")


def shown_matches(value, text):
    """A number shown to 6 significant digits: within half a unit of the 6th."""
    x, shown = float(value), float(text)
    return abs(shown - x) <= 5e-6 * abs(x) + 1e-300


def check_csv_table(name, p, table_id, csv_path, rows=None):
    """The table `table_id` shows the CSV's header and fields (`rows`: the CSV rows it should have; default all)."""
    table = p.tables.get(table_id)
    check(table is not None, f"{name}: no table #{table_id}")
    if table is None:
        return 0
    with open(csv_path, newline="") as f:
        records = list(csv.reader(f))
    header, body = records[0], records[1:] if rows is None else rows
    check([h[0] for h in table["header"]] == header, f"{name} #{table_id}: header {table['header']} != {header}")
    cells = [r for r in table["rows"] if r]
    check(len(cells) == len(body), f"{name} #{table_id}: {len(cells)} rows, {len(body)} in the CSV")
    for row, shown in zip(body, cells):
        check([c[0] for c in shown] == row, f"{name} #{table_id}: row {[c[0] for c in shown]} != CSV {row}")
        for value, (_, text) in zip(row, shown):
            try:
                float(value)
            except ValueError:
                check(text == value, f"{name} #{table_id}: shown {text!r} for {value!r}")
                continue
            check(shown_matches(value, text), f"{name} #{table_id}: shown {text} for {value}")
    return len(cells)


def run(name, scene, extra, plots, views):
    prefix = os.path.join(work, name)
    page = prefix + ".html"
    subprocess.run([modal, "analyze", os.path.join(source, scene), "--csv", prefix, "--report", page] + extra,
                   check=True, stdout=subprocess.DEVNULL)
    p = render(name, page, 3000)  # animated: frames must be drawn
    s = p.status
    check_status(name, p, plots, views)
    with open(prefix + "_modes.csv") as f:
        rows = list(csv.DictReader(f))
    table = [r for r in p.tables.get("modes-table", {"rows": []})["rows"] if r]
    check(len(table) == len(rows), f"{name}: {len(table)} rows in the mode table, {len(rows)} in the CSV")
    columns = ["omega2", "growth_rate", "omega", "frequency_hz", "period", "damping_ratio", None, "error_estimate",
               "residual_bound"]
    for row, cells in zip(rows, table):
        check(cells[0][1] == row["mode"], f"{name}: mode {cells[0][1]} != {row['mode']}")
        for column, (value, text) in zip(columns, cells[1:]):
            if column is None:
                check(text == row["stability"], f"{name}: stability {text} != {row['stability']}")
                continue
            check(value == row[column], f"{name} mode {row['mode']} {column}: data-v {value} != CSV {row[column]}")
            if row[column]:
                check(shown_matches(row[column], text), f"{name} {column}: shown {text} for {row[column]}")
    print(f"{name}: status {s.get('data-plots')} plots, {s.get('data-views')} views, {s.get('data-frames')} frames, "
          f"{len(rows)} modes checked against the CSV")


def study(name, command, scene, extra, plots, tables):
    """`modal COMMAND SCENE --csv NAME.csv --report NAME.html EXTRA`; tables: {table id: CSV suffix or None}."""
    prefix = os.path.join(work, name)
    page = prefix + ".html"
    subprocess.run([modal, command, os.path.join(source, scene), "--csv", prefix + ".csv", "--report", page] + extra,
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    p = render(name, page)
    check_status(name, p, plots)
    checked = []
    for table_id, suffix in tables.items():
        checked.append(f"#{table_id} {check_csv_table(name, p, table_id, prefix + suffix)} rows")
    print(f"{name}: status {p.status.get('data-plots')} plots, tables against the CSV: {', '.join(checked)}")
    return p, prefix


# 2 modes: 2 animated views, 2 energy charts; lattice: 6 views, no plots.
run("double_pendulum", "models/double_pendulum.toml", ["--energy"], plots=2, views=2)
run("lattice", "models/lattice.toml", ["--modes", "6"], plots=0, views=6)
# Complex shapes (dampers and a follower load): views animated with each point's phase.
run("ziegler_damped", "models/ziegler_damped.toml", ["--set", "P=1.5"], plots=0, views=2)
with open(os.path.join(work, "ziegler_damped.html")) as f:
    check('"displacement_imag"' in f.read(), "ziegler_damped: the drawing has no imaginary parts of the shapes")
# Sweeps: a rotating frame (ω², root locus, Campbell), a follower load (Re s, Im s, root locus), the
# convergence in the number of links (ω², root locus, convergence), and a map (one plot).
study("sweep", "sweep", "models/bead_on_hoop_frame.toml", ["--vary", "Omega=0:6:13"], 3,
      {"points-table": ".csv", "critical-table": "_critical.csv"})
study("sweep_follower", "sweep", "models/ziegler.toml", ["--vary", "P=0:4:9"], 3,
      {"points-table": ".csv", "critical-table": "_critical.csv"})
study("sweep_extrapolate", "sweep", "models/hanging_chain.toml", ["--vary", "N=4,8,16,32", "--extrapolate", "--modes", "2"],
      3, {"points-table": ".csv", "critical-table": "_critical.csv", "extrapolation-table": "_extrapolation.csv"})
study("map", "sweep", "models/ziegler.toml", ["--vary", "P=0:4:9", "--vary", "k=0.5:1.5:4"], 1, {"map-table": ".csv"})
study("amplitude", "amplitude", "models/double_pendulum.toml", ["--points", "4", "--cycles", "1"], 2, {"scan-table": ".csv"})
# 5001 samples: drawn as 2000 buckets of minimum and maximum; the table has 21 of the CSV's rows.
p, prefix = study("simulate", "simulate", "models/double_pendulum.toml", ["--duration", "5", "--interval", "0.001"], 2, {})
with open(prefix + ".csv", newline="") as f:
    records = list(csv.reader(f))
by_time = {r[0]: r for r in records[1:]}
shown = [[c[0] for c in r] for r in p.tables.get("samples-table", {"rows": []})["rows"] if r]
check(len(shown) == 21, f"simulate: {len(shown)} rows in the samples table, expected 21")
check(shown and shown[0] == records[1] and shown[-1] == records[-1], "simulate: the first and last samples are not the CSV's")
for row in shown:
    check(by_time.get(row[0]) == row, f"simulate: sample at t = {row[0]} is not the CSV's row")
p, prefix = study("equilibria", "equilibria", "models/double_pendulum.toml", [], 1, {"equilibria-table": ".csv"})
with open(prefix + ".csv", newline="") as f:
    count = len(list(csv.reader(f))) - 1
modes = [t for t in p.tables if t.startswith("modes-")]
check(len(modes) == count, f"equilibria: {len(modes)} frequency tables for {count} equilibria")
print("report_browser: " + (f"{len(failures)} checks failed" if failures else "every check passed"))
sys.exit(1 if failures else 0)
