#!/usr/bin/env python3
"""The HTML report in a browser (ctest label `browser`; docs/design.md, "HTML reports").

Runs `modal analyze --csv --report` on a 2-D scene (the double pendulum, with
--energy) and a 3-D one (the 6x6x6 lattice), opens each page in headless
Chromium from a file:// URL with the network disabled (host names resolve to
nothing, and the proxy is a closed local port), lets its scripts run for 3 s
of virtual time, and asserts on the rendered DOM: the status line the page's
script fills says no script error, the expected number of plots and
animated views and some frames drawn; the mode table's values are the
CSV's, to the last digit (data-v) and as shown (6 significant digits).
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
    """The status attributes and the mode table's cells (data-v and text)."""

    def __init__(self):
        super().__init__()
        self.status, self.rows, self.table, self.cell = {}, [], False, None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id") == "report-status":
            self.status = a
        if tag == "table" and a.get("id") == "modes-table":
            self.table = True
        if self.table and tag == "tr":
            self.rows.append([])
        if self.table and tag == "td":
            self.cell = [a.get("data-v"), ""]
            self.rows[-1].append(self.cell)

    def handle_endtag(self, tag):
        if tag == "table":
            self.table = False
        if tag == "td":
            self.cell = None

    def handle_data(self, data):
        if self.cell is not None:
            self.cell[1] += data


def run(name, scene, extra, plots, views):
    prefix = os.path.join(work, name)
    page = prefix + ".html"
    subprocess.run([modal, "analyze", os.path.join(source, scene), "--csv", prefix, "--report", page] + extra,
                   check=True, stdout=subprocess.DEVNULL)
    dom = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--user-data-dir=" + prefix + "-profile",
                          "--host-resolver-rules=MAP * ~NOTFOUND", "--proxy-server=127.0.0.1:9",
                          "--virtual-time-budget=3000", "--dump-dom", "file://" + os.path.abspath(page)],
                         check=True, capture_output=True, text=True, timeout=120).stdout
    p = Page()
    p.feed(dom)
    s = p.status
    check(s.get("data-done") == "1", f"{name}: the page's script did not finish (status {s})")
    check(s.get("data-errors") == "0", f"{name}: script errors: {s}")
    check(s.get("data-plots") == str(plots), f"{name}: {s.get('data-plots')} plots, expected {plots}")
    check(s.get("data-views") == str(views), f"{name}: {s.get('data-views')} animated views, expected {views}")
    check(int(s.get("data-frames", "0")) > 2 * views, f"{name}: too few frames drawn ({s.get('data-frames')})")
    with open(prefix + "_modes.csv") as f:
        rows = list(csv.DictReader(f))
    table = [r for r in p.rows if r]
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
                # Shown to 6 significant digits: within half a unit of the 6th.
                x, shown = float(row[column]), float(text)
                check(abs(shown - x) <= 5e-6 * abs(x) + 1e-300, f"{name} {column}: shown {text} for {row[column]}")
    print(f"{name}: status {s.get('data-plots')} plots, {s.get('data-views')} views, {s.get('data-frames')} frames, "
          f"{len(rows)} modes checked against the CSV")


# 2 modes: 2 animated views, 2 energy charts; lattice: 6 views, no plots.
run("double_pendulum", "models/double_pendulum.toml", ["--energy"], plots=2, views=2)
run("lattice", "models/lattice.toml", ["--modes", "6"], plots=0, views=6)
print("report_browser: " + (f"{len(failures)} checks failed" if failures else "every check passed"))
sys.exit(1 if failures else 0)
