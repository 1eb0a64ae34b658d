"""Tests of the Python module dbbkit, run by ctest (the standard unittest runner).

The module's JSON is compared with the command line's on the committed designs and the
paper's data; its arrays with that JSON (shapes, units, NaN where not determined); bad
input must raise dbbkit.InputError naming the file or key; Ctrl-C must stop a long run.

Environment (set by ctest): DBBKIT_SOURCE_DIR, DBBKIT_CLI, PYTHONPATH with the module.
"""

import glob
import json
import math
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np

import dbbkit

SOURCE = os.environ["DBBKIT_SOURCE_DIR"]
CLI = os.environ["DBBKIT_CLI"]
PAPER_C = "designs/paper-c-turntable.json"
PAPER_B = "designs/paper-b-head.json"
DATA_C = "tests/data/paper/paper_c_turntable.csv"
DATA_B = "tests/data/paper/paper_b_head.csv"
NAMES = ("dx", "dy", "dz", "ex", "ey", "ez")


def cli_json(*args):
    """The JSON the command line writes with --out (paths relative to the source tree)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.json")
        run = subprocess.run([CLI, *args, "--out", out, "--quiet"], cwd=SOURCE, capture_output=True, text=True)
        if run.returncode not in (0, 1):
            raise AssertionError(f"{args}: exit {run.returncode}: {run.stderr}")
        with open(out) as f:
            return json.load(f)


def cli_text(*args):
    return subprocess.run([CLI, *args], cwd=SOURCE, capture_output=True, text=True, check=True).stdout


def result_file(result, tmp, name="a.json"):
    """The result's JSON written as a file in `tmp` (as identify --out writes it): its path."""
    path = os.path.join(tmp, name)
    with open(path, "w") as f:
        json.dump(result.json, f)
    return path


class InSource(unittest.TestCase):
    def setUp(self):
        self._cwd = os.getcwd()
        os.chdir(SOURCE)

    def tearDown(self):
        os.chdir(self._cwd)


def machine_result(tmp, machine, tests):
    """Each (design, truth) simulated and identified with the command line, then chained: the
    machine result's path."""
    results = []
    for k, (design, truth) in enumerate(tests):
        csv, out = os.path.join(tmp, f"{k}.csv"), os.path.join(tmp, f"{k}.json")
        subprocess.run([CLI, "simulate", "--design", design, "--truth", truth, "--out", csv],
                       cwd=SOURCE, check=True, capture_output=True)
        subprocess.run([CLI, "identify", "--design", design, "--data", csv, "--out", out,
                        "--quiet"], cwd=SOURCE, check=True, capture_output=True)
        results.append(out)
    m = os.path.join(tmp, "M.json")
    subprocess.run([CLI, "chain", "--machine", machine, *results, "--out", m, "--quiet"],
                   cwd=SOURCE, check=True, capture_output=True)
    return m


class RoundTrips(InSource):
    """The same inputs give the same JSON as the command line, to the last digit."""

    def test_identify_on_the_papers_data(self):
        for design, data in ((PAPER_C, DATA_C), (PAPER_B, DATA_B)):
            d = dbbkit.Design(design)
            r = dbbkit.identify(d, dbbkit.Measurements(data, d))
            self.assertEqual(r.json, cli_json("identify", "--design", design, "--data", data), design)

    def test_warnings_come_first_as_in_the_json(self):
        d = dbbkit.Design(PAPER_C)
        r = dbbkit.identify(d, dbbkit.Measurements(DATA_C, d))
        self.assertEqual(r.warnings, r.json["warnings"])
        self.assertEqual(r.warnings[0]["kind"], "residual")
        self.assertIn("dbbkit diagnose", r.warnings[0]["text"])
        e = dbbkit.evaluate(d)
        self.assertEqual([w["kind"] for w in e.warnings], ["setup_undeclared"])
        g = dbbkit.diagnose(d, dbbkit.Measurements(DATA_C, d))
        self.assertEqual(g.warnings, g.json["warnings"])
        # The summary: at most six sentences under 240 characters, the found effect first.
        self.assertEqual(g.brief, g.json["summary"])
        self.assertLessEqual(len(g.brief), 6)
        self.assertTrue(all(len(i["text"]) < 240 for i in g.brief))
        self.assertEqual(g.brief[0]["topic"], "found")
        self.assertIn("installation 2r", g.brief[0]["text"])
        self.assertTrue(g.summary().startswith("summary:\n  - Found:"))

    def test_compare_and_compensation_as_the_command_line(self):
        d = dbbkit.Design(PAPER_C)
        r = dbbkit.identify(d, dbbkit.Measurements(DATA_C, d))
        with tempfile.TemporaryDirectory() as tmp:
            a = result_file(r, tmp)
            c = dbbkit.compare(r, a)
            self.assertEqual(c, cli_json("compare", a, a) | {"inputs": c["inputs"]})
            self.assertEqual(c["significant_changes"], 0)
            text = dbbkit.compensation(r, "isg")
            self.assertEqual(text, cli_text("compensation", "--result", a, "--format", "isg").replace(a, "result"))
            # The decision to enter over an envelope, as --grid-*.
            table = dbbkit.compensation(a, "table", radii_mm=[0, 200], heights_mm=[60], around=4)
            self.assertEqual(table, cli_text("compensation", "--result", a, "--format", "table",
                                             "--grid-radius-mm", "0,200", "--grid-height-mm", "60",
                                             "--grid-around", "4"))
            self.assertIn("Over the envelope (", table)
            with self.assertRaises(dbbkit.InputError) as ctx:
                dbbkit.compensation(a, "table", around=4)
            self.assertIn("around: a map's parameter", str(ctx.exception))
        with self.assertRaises(dbbkit.InputError):
            dbbkit.compensation(r, "linuxcnc")  # a C table: the module must be named

    def test_verify_as_the_command_line(self):
        # A held-out test of the A trunnion: the dict verify --out writes, a pass and, with Y0A
        # left out of the result, a fail naming Y0A; another axis' test refused.
        a_design = "designs/a-trunnion.json"
        k_design = "tests/data/a_trunnion_kit_optimized.json"
        truth = "tests/data/truth_a_trunnion_location.json"
        with tempfile.TemporaryDirectory() as tmp:
            a_csv, k_csv = os.path.join(tmp, "a.csv"), os.path.join(tmp, "k.csv")
            for args in (["--design", a_design, "--out", a_csv],
                         ["--design", k_design, "--seed", "9", "--out", k_csv]):
                subprocess.run([CLI, "simulate", "--truth", truth, *args], cwd=SOURCE, check=True,
                               capture_output=True)
            d = dbbkit.Design(a_design)
            a = result_file(dbbkit.identify(d, dbbkit.Measurements(a_csv, d)), tmp)
            k = dbbkit.Design(k_design)
            got = dbbkit.verify(a, k, dbbkit.Measurements(k_csv, k))
            self.assertTrue(got["pass"])
            self.assertEqual(got, cli_json("verify", "--result", a, "--design", k_design,
                                           "--data", k_csv))
            with open(a) as f:
                left_out = json.load(f)
            for q in left_out["iso230"]["location"]:
                if q["name"] == "Y0A":
                    q["value"] = 0.0
            fail = dbbkit.verify(left_out, k, dbbkit.Measurements(k_csv, k))
            self.assertFalse(fail["pass"])
            self.assertEqual(fail["explanations"][0]["name"], "Y0A")
            with self.assertRaises(dbbkit.InputError) as ctx:
                dbbkit.verify(a, dbbkit.Design(PAPER_C), dbbkit.Measurements(DATA_C, dbbkit.Design(PAPER_C)))
            self.assertIn("axis", str(ctx.exception))
            with self.assertRaises(dbbkit.InputError) as ctx:
                dbbkit.verify(a, k, dbbkit.Measurements(k_csv, k), coverage=1.5)
            self.assertIn("coverage", str(ctx.exception))
            # The test's readings before it is run, as predict --design; the result as its
            # JSON text is hashed as text, not opened as a file's name.
            before = dbbkit.predict(a, design=k)
            self.assertEqual(before, cli_json("predict", "--result", a, "--design", k_design))
            self.assertEqual(len(before["readings"]), 63)
            with open(a) as f:
                text = f.read()
            as_text = dbbkit.predict(text, design=k)
            self.assertEqual(as_text["inputs"]["result_sha256"], before["inputs"]["result_sha256"])
            self.assertEqual(as_text["readings"], before["readings"])
            checked = dbbkit.verify(text, k, dbbkit.Measurements(k_csv, k))
            self.assertEqual(checked["inputs"]["result_sha256"], got["inputs"]["result_sha256"])
            with self.assertRaises(dbbkit.InputError) as ctx:
                dbbkit.predict(a, at=[[0, 100, 0, 0]], design=k)
            self.assertIn("one of them", str(ctx.exception))

    def test_predict_a_machine_result_as_the_command_line(self):
        # The A/C trunnion's chain at poses: the CSV or rows [A_deg, C_deg, x, y, z]; the dict
        # predict --out writes.
        with tempfile.TemporaryDirectory() as tmp:
            m = machine_result(tmp, "designs/machines/a-c-trunnion.json",
                               [(f"designs/a-c-trunnion-{a}.json",
                                 f"tests/data/truth_a_c_trunnion_{a}.json") for a in ("A", "C")])
            poses = "tests/data/poses_a_c_trunnion.csv"
            got = dbbkit.predict(m, at=os.path.join(SOURCE, poses))
            cli = cli_json("predict", "--result", m, "--at", poses)
            self.assertEqual(got["inputs"]["poses"], os.path.join(SOURCE, poses))
            got["inputs"]["poses"] = poses
            self.assertEqual(got, cli)
            rows = dbbkit.predict(m, at=[[90, 0, 100, 0, -60]])
            self.assertEqual(rows["points"][0]["error_um"], got["points"][1]["error_um"])
            with open(m) as f:
                text = f.read()
            self.assertEqual(dbbkit.predict(text, at=[[90, 0, 100, 0, -60]])["points"],
                             rows["points"])
            with self.assertRaises(dbbkit.InputError) as ctx:
                dbbkit.predict(m, at=[[90, 100, 0, -60]])
            self.assertIn("expected rows of 5 numbers", str(ctx.exception))

    def test_predict_a_tool_tip_against_a_table_as_the_command_line(self):
        # The paper's B/C machine: rows [B_deg, C_deg, x, y, z, tool_x, tool_y, tool_z] (the
        # chain's order) or the CSV; the error is the tool tip's less the workpiece point's.
        with tempfile.TemporaryDirectory() as tmp:
            m = machine_result(tmp, "designs/machines/paper-b-c.json",
                               [("designs/paper-b-c-B-off-axis.json",
                                 "tests/data/truth_paper_b_c_B.json"),
                                ("designs/paper-b-c-C.json", "tests/data/truth_paper_b_c_C.json")])
            poses = "tests/data/poses_paper_b_c.csv"
            got = dbbkit.predict(m, at=os.path.join(SOURCE, poses))
            got["inputs"]["poses"] = poses
            self.assertEqual(got, cli_json("predict", "--result", m, "--at", poses))
            rows = dbbkit.predict(m, at=[[-90, 90, 0, 0, 150, 0, 0, 100]])
            point = rows["points"][0]
            self.assertEqual(point, got["points"][2])
            for axis in range(3):
                self.assertAlmostEqual(point["error_um"][axis],
                                       point["tool_um"][axis] - point["workpiece_um"][axis],
                                       places=5)
            with self.assertRaises(dbbkit.InputError) as ctx:
                dbbkit.predict(m, at=[[-90, 90, 0, 0, 150]])
            self.assertIn("expected rows of 8 numbers", str(ctx.exception))
            # Rows that are not numbers are named by row and column, never cast.
            for rows, says in (([[0, 0, 0, 0, 0, 0, 0, True]], "at[0].tool_z_mm: not a number"),
                               ([[0, "0", 0, 0, 0, 0, 0, 100]], "at[0].C_deg: not a number"),
                               ([[0, 0, 0, 0, 0, 0, None, 100]], "at[0].tool_y_mm: not a number"),
                               (5, "expected rows of 8 numbers"),
                               ([0, 0, 0, 0, 0, 0, 0, 100], "at[0]: expected rows"),
                               ([[0, 0, 0, 0, 0, 0, 0, 1e300]], "at[0], column tool_z_mm")):
                with self.assertRaises(dbbkit.InputError, msg=str(rows)) as ctx:
                    dbbkit.predict(m, at=rows)
                self.assertIn(says, str(ctx.exception))
            # Its Siemens record (kinematic type M) as the command line writes it.
            record = dbbkit.compensation(m, "siemens", record=1, tool_reference_mm=[0, 0, 100])
            self.assertIn("kinematic type M", record)
            self.assertEqual(record, subprocess.run(
                [CLI, "compensation", "--result", m, "--format", "siemens", "--record", "1",
                 "--tool-reference-mm", "0,0,100"], cwd=SOURCE, check=True,
                capture_output=True, text=True).stdout)
            with self.assertRaises(dbbkit.InputError) as ctx:
                dbbkit.compensation(m, "siemens", record=1)
            self.assertIn("tool_reference_mm: required", str(ctx.exception))
            with self.assertRaises(dbbkit.InputError) as ctx:
                dbbkit.compensation(m, "siemens", record=1, tool_reference_mm=[0, 0])
            self.assertIn("tool_reference_mm", str(ctx.exception))

    def test_predict_as_the_command_line(self):
        # The poses' CSV or rows; the dict predict --out writes; bad rows name their place.
        d = dbbkit.Design(PAPER_C)
        r = dbbkit.identify(d, dbbkit.Measurements(DATA_C, d))
        with tempfile.TemporaryDirectory() as tmp:
            a = result_file(r, tmp)
            rows = [[0, 200, 0, 50], [10, 200, 0, 50]]
            csv = os.path.join(tmp, "poses.csv")
            with open(csv, "w") as f:
                f.write("angle_deg,x_mm,y_mm,z_mm\n" + "".join("%g,%g,%g,%g\n" % tuple(x) for x in rows))
            got = dbbkit.predict(a, csv)
            self.assertEqual(got, cli_json("predict", "--result", a, "--at", csv))
            from_rows = dbbkit.predict(a, np.array(rows, dtype=float))
            self.assertEqual(from_rows["points"], got["points"])
            self.assertEqual([p["basis"] for p in got["points"]], ["motions", "location"])
            only = dbbkit.predict(a, rows, location_only=True)
            self.assertEqual([p["basis"] for p in only["points"]], ["location", "location"])
            # A map over the envelope: the command line's, point for point.
            grid = dbbkit.predict(a, radii_mm=[0, 200], heights_mm=[0, 50], around=4)
            self.assertEqual(grid, cli_json("predict", "--result", a, "--grid-radius-mm", "0,200",
                                            "--grid-height-mm", "0,50", "--grid-around", "4"))
            self.assertEqual(len(grid["points"]), len(r.json["errors"]) * 2 * (1 + 4))
        with self.assertRaises(dbbkit.InputError) as ctx:
            dbbkit.predict(r, [[0, 1, 2, 3]], radii_mm=[100])
        self.assertIn("not both", str(ctx.exception))
        # A map's arguments as the command line's options: named, each checked.
        for kwargs, says in [({}, "give the poses (at), a map (radii_mm) or a test (design)"),
                             ({"heights_mm": [0]}, "heights_mm: a map's parameter"),
                             ({"around": 4}, "around: a map's parameter"),
                             ({"radii_mm": []}, "radii_mm: no radius"),
                             ({"radii_mm": [10], "heights_mm": []}, "heights_mm: no height"),
                             ({"radii_mm": [10, 10]}, "radii_mm: item 2: 10 is item 1 as well"),
                             ({"radii_mm": [1e-9]}, "radii_mm: item 1"),
                             ({"radii_mm": [10], "around": 2.5}, "around: expected a whole"),
                             ({"radii_mm": [10], "around": True}, "around: expected a whole"),
                             ({"radii_mm": [10], "around": 10**30}, "around"),
                             ({"radii_mm": [10], "angles_deg": [float("inf")]},
                              "angles_deg: item 1: not a finite number")]:
            with self.assertRaises(dbbkit.InputError, msg=str(kwargs)) as ctx:
                dbbkit.predict(r, **kwargs)
            self.assertIn(says, str(ctx.exception))
        self.assertEqual(dbbkit.predict(r, radii_mm=[10], around=np.int64(3),
                                        angles_deg=[0])["grid"]["around"], 3)
        with self.assertRaises(dbbkit.InputError) as ctx:
            dbbkit.predict(r, [[0, 1, 2]])
        self.assertIn("at[0]", str(ctx.exception))
        with self.assertRaises(dbbkit.InputError) as ctx:
            dbbkit.predict(r, [[0, 1, 2, float("nan")]])
        self.assertIn("at[0].z_mm", str(ctx.exception))

    def test_a_machine_design_its_program_and_chain_as_the_command_line(self):
        # A design that names its machine (relative to its own folder), a program that needs
        # tcpm, and chain of two axes' results, the dict chain --out writes.
        a = dbbkit.Design("designs/a-c-trunnion-A.json")
        c = dbbkit.Design("designs/a-c-trunnion-C.json")
        with self.assertRaises(dbbkit.InputError) as ctx:
            dbbkit.program(c, "sinumerik")
        self.assertIn("tcpm", str(ctx.exception))
        self.assertIn("TRAORI", dbbkit.program(c, "sinumerik", tcpm="on"))
        with tempfile.TemporaryDirectory() as tmp:
            files = []
            for d, name, truth in ((a, "A", {"Y0A": 20}), (c, "C", {"Y0C": 35, "B0C": 30})):
                csv = os.path.join(tmp, name + ".csv")
                tf = os.path.join(tmp, name + "-truth.json")
                with open(tf, "w") as f:
                    json.dump({"format": "dbbkit.truth/1", "location": truth, "geometry": "exact",
                               "seed": 3}, f)
                subprocess.run([CLI, "simulate", "--design", "designs/a-c-trunnion-%s.json" % name,
                                "--truth", tf, "--out", csv, "--quiet"], check=True, cwd=SOURCE)
                r = dbbkit.identify(d, dbbkit.Measurements(csv, d))
                files.append(result_file(r, tmp, name + ".json"))
            machine = "designs/machines/a-c-trunnion.json"
            got = dbbkit.chain(machine, files)
            self.assertEqual(got, cli_json("chain", "--machine", machine, *files))
            # The results' JSON text serves as well (no file: no SHA-256).
            texts = [open(f).read() for f in files]
            from_text = dbbkit.chain(machine, texts)
            self.assertEqual(from_text["chain"], got["chain"])
            self.assertNotIn("result_sha256", from_text["axes"][0])
            dist = [t for t in got["chain"] if t["name"] == "distance"][0]
            self.assertLessEqual(abs(dist["value"] - 15), dist["U"])
            with self.assertRaises(dbbkit.InputError):
                dbbkit.chain(machine, files[:1])
            # The corrected kinematics from the dict chain gives: the text the command writes
            # from the file (the file's path in its first line aside).
            m_file = os.path.join(tmp, "M.json")
            with open(m_file, "w") as f:
                json.dump(got, f)
            for fmt, extra in (("siemens", ["--record", "2"]), ("table", []), ("isg", [])):
                kw = {"record": 2} if extra else {}
                text = dbbkit.compensation(got, fmt, **kw)
                cli = cli_text("compensation", "--result", m_file, "--format", fmt, *extra)
                self.assertEqual(text.split("\n")[1:], cli.split("\n")[1:])
                self.assertEqual(dbbkit.compensation(m_file, fmt, **kw), cli)
            self.assertIn("$TC_CARR5[2]=", dbbkit.compensation(got, "siemens", record=2))
            with self.assertRaises(dbbkit.InputError) as ctx:
                dbbkit.compensation(got, "siemens")
            self.assertIn("record", str(ctx.exception))

    def test_messages_are_one_line_whatever_the_names(self):
        # An installation id or an effect label from the caller is quoted with its line break
        # escaped: a message never breaks a log line.
        d = dbbkit.Design(PAPER_C)
        with self.assertRaises(dbbkit.InputError) as ctx:
            dbbkit.Measurements.from_trace(d, {"1r\nX": (np.arange(100.0), np.zeros(100))})
        self.assertNotIn("\n", str(ctx.exception))
        self.assertIn("'1r\\nX'", str(ctx.exception))
        m = dbbkit.Measurements(DATA_C, d)
        with self.assertRaises(dbbkit.InputError) as ctx:
            dbbkit.identify(d, m, effects=["length_offset[9\nz]"])
        self.assertNotIn("\n", str(ctx.exception))

    def test_a_path_with_a_nul_byte_reads_no_other_file(self):
        # The system reads a name up to its first NUL: PAPER_C + NUL + anything would be PAPER_C.
        d = dbbkit.Design(PAPER_C)
        r = dbbkit.identify(d, dbbkit.Measurements(DATA_C, d))
        with tempfile.TemporaryDirectory() as tmp:
            a = result_file(r, tmp)
            for call in (lambda: dbbkit.Design(PAPER_C + "\0.other"),
                         lambda: dbbkit.Measurements(DATA_C + "\0.other", d),
                         lambda: dbbkit.compare(a + "\0x", a),
                         lambda: dbbkit.compensation(a.encode() + b"\0x", "isg"),
                         lambda: dbbkit.Measurements.from_trace(d, {"1r": DATA_C + "\0x"})):
                with self.assertRaises(dbbkit.InputError) as ctx:
                    call()
                self.assertIn("NUL byte", str(ctx.exception))

    def test_identify_with_tolerances_type_a_and_coverage(self):
        tol = "designs/tolerances/c-turntable-acceptance.json"
        d = dbbkit.Design(PAPER_C)
        r = dbbkit.identify(d, dbbkit.Measurements(DATA_C, d), type_a=True, coverage=0.99, tolerances=tol)
        expected = cli_json("identify", "--design", PAPER_C, "--data", DATA_C, "--type-a", "--coverage", "0.99",
                            "--tolerances", tol)
        self.assertEqual(r.json, expected)
        verdict = expected["conformance"]["verdict"]
        cli = subprocess.run([CLI, "identify", "--design", PAPER_C, "--data", DATA_C, "--type-a", "--coverage",
                              "0.99", "--tolerances", tol, "--quiet", "--out", "-"], cwd=SOURCE, capture_output=True)
        self.assertEqual(r.conforms, cli.returncode == 0, verdict)  # exit 1: does not conform
        self.assertIn(tol, r.report("markdown"))  # the conditions name (and hash) the tolerance file, as the CLI's

    def test_diagnose_with_tolerances(self):
        tol = "designs/tolerances/c-turntable-acceptance.json"
        d = dbbkit.Design(PAPER_C)
        r = dbbkit.diagnose(d, dbbkit.Measurements(DATA_C, d), tolerances=tol)
        expected = cli_json("diagnose", "--design", PAPER_C, "--data", DATA_C, "--tolerances", tol)
        self.assertEqual(r.json, expected)
        self.assertEqual(expected["conformance"]["errors"], "corrected")
        self.assertFalse(r.conforms)  # the paper's axis lies 153 um off centre: Y0C does not conform
        self.assertIn("conformance of the corrected errors", r.summary())
        self.assertIn(tol, r.report("markdown"))
        self.assertIsNone(dbbkit.diagnose(d, dbbkit.Measurements(DATA_C, d)).conforms)

    def test_identify_with_effects(self):
        d = dbbkit.Design(PAPER_C)
        m = dbbkit.Measurements(DATA_C, d)
        r = dbbkit.identify(d, m, effects=["length_offset[2r]", "centring[2r]"])
        self.assertEqual(r.json, cli_json("identify", "--design", PAPER_C, "--data", DATA_C,
                                          "--effects", "length_offset[2r],centring[2r]"))
        self.assertEqual([e["label"] for e in r.json["effects"]], ["length_offset[2r]", "centring[2r]"])
        self.assertEqual(dbbkit.identify(d, m, effects="length_offset[2r], centring[2r]").json, r.json)
        self.assertIn("effects fitted with the errors", r.summary())
        with self.assertRaises(dbbkit.InputError) as ctx:
            dbbkit.identify(d, m, effects=["length_offset[9z]"])
        self.assertEqual(ctx.exception.source, "effects")
        with self.assertRaises(dbbkit.InputError) as ctx:
            dbbkit.identify(d, m, effects=[3])
        self.assertEqual(ctx.exception.where, "effects")

    def test_from_trace_refuses_bad_arrays_units_and_sizes(self):
        d = dbbkit.Design(PAPER_C)
        t = np.arange(100) * 0.01
        # Wrong shapes, named by argument.
        with self.assertRaises(ValueError) as ctx:
            dbbkit.Measurements.from_trace(d, {"1r": (np.zeros((100, 2)), t)})
        self.assertIn("traces['1r'][0] (time_s)", str(ctx.exception))
        self.assertIn("1-D", str(ctx.exception))
        with self.assertRaises(ValueError) as ctx:
            dbbkit.Measurements.from_trace(d, {"1r": (t, np.zeros(99))})
        self.assertIn("traces['1r']", str(ctx.exception))
        self.assertIn("time_s has 100 values, reading_um 99", str(ctx.exception))
        # A unit that is none, without columns: refused by name.
        with self.assertRaises(dbbkit.InputError) as ctx:
            dbbkit.Measurements.from_trace(d, {"1r": (t, np.zeros(100))}, unit="furlong")
        self.assertIn("furlong", str(ctx.exception))
        # More samples than a trace may hold: refused before they are copied or searched.
        big = np.broadcast_to(np.float64(0), (50_000_001,))
        start = time.monotonic()
        with self.assertRaises(dbbkit.InputError) as ctx:
            dbbkit.Measurements.from_trace(d, {"1r": (big, big)})
        self.assertIn("50000000", str(ctx.exception))
        self.assertLess(time.monotonic() - start, 2.0)

    def test_measurements_from_trace(self):
        d = dbbkit.Design(PAPER_C)
        with tempfile.TemporaryDirectory() as tmp:
            subprocess.run([CLI, "simulate", "--design", PAPER_C, "--truth", "tests/data/truth_c_per_angle.json",
                            "--seed", "4", "--out", os.path.join(tmp, "sim.csv"),
                            "--trace-out", tmp + "/"], cwd=SOURCE, check=True)
            ids = d.installations
            self.assertTrue(all(os.path.exists(os.path.join(tmp, i + ".csv")) for i in ids))
            traces = {i: os.path.join(tmp, i + ".csv") for i in ids}
            m, found = dbbkit.Measurements.from_trace(d, traces)
            args = ["readings", "--design", PAPER_C, "--quiet"]
            for i in ids:
                args += ["--trace", f"{i}={traces[i]}"]
            self.assertEqual(m.to_csv(), cli_text(*args))
            dw = found["dwells"][ids[0]]
            self.assertEqual(len(dw["level_um"]), len(d.angles_deg))
            self.assertTrue(all(s > 100 for s in m.samples))
            # The same trace as arrays.
            data = np.loadtxt(traces[ids[0]], delimiter=",", comments="#", skiprows=2)
            m2, _ = dbbkit.Measurements.from_trace(d, {ids[0]: (data[:, 0], data[:, 1])})
            np.testing.assert_allclose(m2.reading_um, m.reading_um[: len(m2)], atol=1e-9)
            with self.assertRaises(dbbkit.InputError):
                dbbkit.Measurements.from_trace(d, {ids[0]: traces[ids[0]]}, dwell_s=6)
            # One file for two installations: refused, naming both.
            with self.assertRaises(dbbkit.InputError) as ctx:
                dbbkit.Measurements.from_trace(d, {ids[0]: traces[ids[0]], ids[1]: traces[ids[0]]})
            self.assertIn(f"installations '{ids[0]}' and '{ids[1]}'", str(ctx.exception))
            # Each trace on its own clock: said; on the test's clock with a start for each.
            self.assertTrue(any(w["kind"] == "trace_clock" for w in found["warnings"]))
            starts = {i: 1000.0 * k for k, i in enumerate(ids)}
            m3, found3 = dbbkit.Measurements.from_trace(d, traces, start_s=starts)
            self.assertFalse(any(w["kind"] == "trace_clock" for w in found3["warnings"]))
            np.testing.assert_allclose(np.array(m3.time_s) - np.array(m.time_s),
                                       [starts[i] for i in m.installation])
            args += [f"--start={i}={starts[i]:g}" for i in ids]
            self.assertEqual(m3.to_csv(), cli_text(*args))
            with self.assertRaises(dbbkit.InputError):
                dbbkit.Measurements.from_trace(d, traces, start_s={ids[0]: 0.0})
            # Each reading's Type A, into identify's budget beside the declared noise.
            self.assertTrue(all(u > 0 for u in m.u_a_um) and all(n >= 1 for n in m.u_a_dof))
            r = dbbkit.identify(d, m, type_a_readings=True)
            names = [c["name"] for c in r.json["budget"]["values"][0]["components"]]
            self.assertEqual(names, ["reading noise", "reading repeatability"])
            with self.assertRaises(dbbkit.InputError):
                dbbkit.identify(d, m, type_a_readings=True, monte_carlo=True)

    def test_identify_with_monte_carlo(self):
        d = dbbkit.Design(PAPER_C)
        r = dbbkit.identify(d, dbbkit.Measurements(DATA_C, d), monte_carlo=True, mc_seed=7, mc_threads=2)
        self.assertEqual(r.json, cli_json("identify", "--design", PAPER_C, "--data", DATA_C, "--monte-carlo",
                                          "--mc-seed", "7", "--mc-threads", "2"))
        a = r.monte_carlo.arrays
        self.assertEqual(len(a["mean"]), len(r.json["monte_carlo"]["values"]))
        self.assertGreaterEqual(r.monte_carlo.trials, 10000)

    def test_diagnose_on_the_papers_data(self):
        for design, data in ((PAPER_C, DATA_C), (PAPER_B, DATA_B)):
            d = dbbkit.Design(design)
            r = dbbkit.diagnose(d, dbbkit.Measurements(data, d))
            self.assertEqual(r.json, cli_json("diagnose", "--design", design, "--data", data), design)

    def test_evaluate_every_committed_design(self):
        designs = sorted(glob.glob("designs/*.json"))
        self.assertGreaterEqual(len(designs), 8)
        for design in designs:
            r = dbbkit.evaluate(dbbkit.Design(design))
            self.assertEqual(r.json, cli_json("evaluate", "--design", design), design)

    def test_optimize_the_formats_kit(self):
        kit = "designs/kits/c-turntable-kit.json"
        r = dbbkit.optimize(dbbkit.Kit(kit), reference=dbbkit.Design(PAPER_C))
        with tempfile.TemporaryDirectory() as tmp:
            design_out, result_out = os.path.join(tmp, "d.json"), os.path.join(tmp, "r.json")
            subprocess.run([CLI, "optimize", "--kit", kit, "--reference", PAPER_C, "--out", design_out,
                            "--result", result_out, "--quiet"], cwd=SOURCE, check=True)
            with open(result_out) as f:
                expected = json.load(f)
            with open(design_out) as f:
                expected_design = json.load(f)
        got = r.json
        for j in (got, expected):
            del j["seconds"]  # the search's own time
        self.assertEqual(got, expected)
        self.assertEqual(r.design.to_dict(), expected_design)

    def test_simulate(self):
        truth = "tests/data/truth_c_per_angle.json"
        d = dbbkit.Design(PAPER_C)
        m = dbbkit.simulate(d, truth, seed=11)
        self.assertEqual(m.to_csv(), cli_text("simulate", "--design", PAPER_C, "--truth", truth, "--seed", "11"))
        with open(truth) as f:
            as_dict = json.load(f)
        self.assertEqual(dbbkit.simulate(d, as_dict, seed=11).to_csv(), m.to_csv())

    def test_design_from_a_dict(self):
        d = dbbkit.Design(PAPER_C)
        again = dbbkit.Design(d.to_dict())
        self.assertEqual(again.to_dict(), d.to_dict())
        with open(PAPER_C) as f:
            raw = json.load(f)
        m = dbbkit.Measurements(DATA_C, d)
        from_dict = dbbkit.identify(dbbkit.Design(raw), m).json
        from_file = dbbkit.identify(d, m).json
        self.assertEqual(from_dict["inputs"]["design"], "design")
        from_dict["inputs"] = from_file["inputs"]
        self.assertEqual(from_dict, from_file)

    def test_axis_letter_and_frame(self):
        c = dbbkit.Design(PAPER_C)
        self.assertEqual(c.axis, "C")
        self.assertEqual(c.axis_frame["shorthand"], "C")
        self.assertEqual(c.axis_frame["direction"], [0.0, 0.0, 1.0])
        self.assertEqual(c.axis_frame["travel_deg"], "full_turn")
        b = dbbkit.Design("designs/paper-b-head.json")
        self.assertEqual(b.axis, "B")
        self.assertEqual(b.axis_frame["side"], "head")
        self.assertEqual(b.axis_frame["ball_axes"]["D"], [0.0, 1.0, 0.0])  # the shorthand's D
        self.assertIsNone(b.axis_frame["ball_axes"]["H"])
        with open(PAPER_C) as f:
            raw = json.load(f)
        raw["axis"] = {"letter": "A", "side": "table", "direction": [1, 0, 0], "reference": [0, 0, 1],
                       "travel_deg": [-120, 120]}
        raw["angles_deg"] = {"start": -100, "stop": 100, "step": 20}
        a = dbbkit.Design(raw)
        self.assertEqual(a.axis, "A")
        self.assertIsNone(a.axis_frame["shorthand"])
        self.assertEqual(a.axis_frame["travel_deg"], [-120.0, 120.0])
        self.assertEqual(a.axis_frame["ball_axes"]["H"], [1.0, 0.0, 0.0])
        self.assertEqual(dbbkit.Design(a.to_dict()).axis_frame, a.axis_frame)

    def test_measurements_from_arrays_and_csv(self):
        d = dbbkit.Design(PAPER_C)
        m = dbbkit.Measurements(DATA_C, d)
        arrays = dbbkit.Measurements.from_arrays(d, m.installation, m.angle_deg, m.reading_um, time_s=m.time_s)
        with open(DATA_C) as f:
            text = dbbkit.Measurements.from_csv(f.read(), d)
        for other in (arrays, text):
            np.testing.assert_array_equal(dbbkit.identify(d, other).values, dbbkit.identify(d, m).values)


    def test_program_and_setup_sheet_as_the_command_line(self):
        d = dbbkit.Design("designs/c-turntable-kit-optimized.json")
        k = dbbkit.Kit("designs/kits/c-turntable-kit.json")
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "p.h")
            subprocess.run([CLI, "program", "--design", "designs/c-turntable-kit-optimized.json",
                            "--kit", "designs/kits/c-turntable-kit.json", "--dialect", "heidenhain",
                            "--sweeps", "both", "--tool", "7", "--out", out, "--quiet"],
                           cwd=SOURCE, check=True)
            with open(out) as f:
                self.assertEqual(dbbkit.program(d, "heidenhain", kit=k, sweeps="both", tool=7), f.read())
            md = os.path.join(tmp, "s.md")
            printed = subprocess.run([CLI, "setup-sheet", "--design", "designs/c-turntable-kit-optimized.json",
                                      "--kit", "designs/kits/c-turntable-kit.json", "--summary", md],
                                     cwd=SOURCE, capture_output=True, text=True, check=True).stdout
        sheet = dbbkit.setup_sheet(d, kit=k)
        self.assertEqual(sheet.summary(), printed)
        self.assertTrue(sheet.fits_kit)
        self.assertEqual(sorted(sheet.order), sorted(d.to_dict()["installations"][i]["id"]
                                                      for i in range(len(d.to_dict()["installations"]))))
        self.assertIn("<svg", sheet.report("html"))
        for call, where in ((lambda: dbbkit.program(d, "fanuc"), "dialect"),
                            (lambda: dbbkit.program(d, "iso", dwell_s=0), "dwell_s"),
                            (lambda: dbbkit.program(d, "iso", dwell_s=1e-4), "dwell_s"),
                            (lambda: dbbkit.program(d, "iso", feed_mm_min=0.5), "feed_mm_min"),
                            (lambda: dbbkit.program(d, "heidenhain", program_number=3), "program_number"),
                            (lambda: dbbkit.setup_sheet(d, sweeps="up"), "sweeps")):
            with self.assertRaises(dbbkit.InputError) as ctx:
                call()
            self.assertEqual(ctx.exception.where, where)

    def test_iso230_typed_as_the_json(self):
        d = dbbkit.Design(PAPER_C)
        m = dbbkit.Measurements(DATA_C, d)
        for r, block in ((dbbkit.identify(d, m), "iso230"), (dbbkit.diagnose(d, m), "iso230")):
            iso = r.iso230
            # The JSON rounds to 1e-6.
            for q, j in zip(iso.location, r.json[block]["location"]):
                self.assertEqual((q.name, q.unit), (j["name"], j["unit"]))
                self.assertAlmostEqual(q.value, j["value"], delta=5.1e-7)
                self.assertAlmostEqual(q.std, j["std"], delta=5.1e-7)
            self.assertEqual(iso["X0C"].name, "X0C")
            self.assertEqual(iso.components.shape, (len(iso.component_angles_deg), 6))
            names = iso.component_names
            for row, j in zip(iso.components, r.json[block]["components"]):
                for c, name in enumerate(names):
                    self.assertAlmostEqual(row[c], j[name]["value"], delta=5.1e-7)
            with self.assertRaises(KeyError):
                iso["XOC9"]

    def test_covariance_after_diagnose(self):
        d = dbbkit.Design(PAPER_C)
        g = dbbkit.diagnose(d, dbbkit.Measurements(DATA_C, d))
        c = g.covariance_after()
        n = g.std_after.size
        self.assertEqual(c.shape, (n, n))
        np.testing.assert_allclose(c, c.T, rtol=0, atol=1e-12)
        diag = np.diag(c).reshape(g.std_after.shape)
        # The attributions' share is in std_after alone: the diagonal never exceeds it, and
        # equals it where the equivalent effects change nothing (dz, ez of the paper's C data).
        self.assertTrue(np.all(diag <= g.std_after ** 2 * (1 + 1e-9)))
        for k in (2, 5):
            np.testing.assert_allclose(diag[:, k], g.std_after[:, k] ** 2, rtol=1e-9)
        self.assertTrue(np.any(diag[:, 0] < 0.5 * g.std_after[:, 0] ** 2))

    def test_sweep_and_repeat_columns(self):
        d = dbbkit.Design("tests/data/c_fourier2_bar150.json")
        m = dbbkit.simulate(d, "tests/data/truth_drift_example.json", seed=3)
        self.assertEqual(len(m.sweep), len(m))
        self.assertEqual(set(m.sweep), {"ccw", "cw"})
        again = dbbkit.Measurements.from_csv(m.to_csv(), d)
        self.assertEqual(again.sweep, m.sweep)
        self.assertEqual(again.repeat, m.repeat)
        self.assertTrue(all(r is None or isinstance(r, int) for r in m.repeat))


class Arrays(InSource):
    """NumPy arrays of the right shape and units, equal to the JSON's values."""

    @classmethod
    def setUpClass(cls):
        d = dbbkit.Design(os.path.join(SOURCE, PAPER_C))
        cls.m = dbbkit.Measurements(os.path.join(SOURCE, DATA_C), d)
        cls.r = dbbkit.identify(d, cls.m)

    def test_errors_per_angle(self):
        r = self.r
        stations = len(r.json["errors"])
        self.assertEqual(stations, 18)  # 0..340 deg; 360 is 0
        for name in ("values", "std", "U", "k"):
            self.assertEqual(getattr(r, name).shape, (stations, 6), name)
            self.assertEqual(getattr(r, name).dtype, np.float64, name)
        self.assertEqual(r.determined.dtype, np.bool_)
        np.testing.assert_array_equal(r.angles_deg, [e["angle_deg"] for e in r.json["errors"]])
        self.assertEqual(r.json["units"], dict(zip(NAMES, dbbkit.ERROR_UNITS)))
        for s, e in enumerate(r.json["errors"]):
            for k, name in enumerate(NAMES):
                for array, key in ((r.values, "value"), (r.std, "std"), (r.U, "U")):
                    if e[key][name] is None:
                        self.assertTrue(math.isnan(array[s, k]))
                        self.assertFalse(r.determined[s, k])
                    else:
                        self.assertAlmostEqual(array[s, k], e[key][name], delta=1e-6)

    def test_covariance(self):
        r = self.r
        c = r.covariance()
        self.assertEqual(c.shape, (6 * 18, 6 * 18))
        np.testing.assert_allclose(np.sqrt(np.diag(c)), r.std.ravel(), rtol=1e-9)
        self.assertTrue(np.allclose(c, c.T))
        self.assertGreater(np.linalg.eigvalsh(c).min(), -1e-9 * np.abs(c).max())

    def test_residuals_and_singular_values(self):
        r = self.r
        self.assertEqual(r.residuals_um.shape, (len(self.m),))
        self.assertAlmostEqual(math.sqrt(np.mean(r.residuals_um ** 2)), r.json["residual"]["rms_um"], delta=1e-6)
        self.assertEqual(r.singular_values.shape, (r.n_unknowns,))
        self.assertTrue(np.all(np.diff(r.singular_values) <= 0))
        self.assertEqual(r.rank, r.json["rank"])
        self.assertEqual((r.chi2 > 0, r.dof), (True, r.json["residual"]["dof"]))

    def test_diagnose_before_and_after(self):
        d = dbbkit.Design(os.path.join(SOURCE, PAPER_C))
        g = dbbkit.diagnose(d, self.m)
        self.assertEqual(g.values_before.shape, g.values_after.shape)
        self.assertEqual(g.residuals_after_um.shape, (len(self.m),))
        self.assertAlmostEqual(g.rms_before_um, g.json["before"]["rms_um"], delta=1e-6)
        self.assertEqual([a["label"] for a in g.added], ["length_offset[2r]", "centring[2r]"])

    def test_evaluate_arrays(self):
        e = dbbkit.evaluate(dbbkit.Design(os.path.join(SOURCE, PAPER_C)))
        self.assertEqual(e.std.shape, (18, 6))
        self.assertAlmostEqual(np.nanmax(e.std[:, :3]), e.json["worst_std_um"], delta=1e-6)
        self.assertIsNone(e.std_total)
        self.assertEqual(e.singular_values.shape, (e.n_unknowns,))


class BadInput(InSource):
    """The readers' errors, as dbbkit.InputError (a ValueError) naming the file or key."""

    def assertInputError(self, call, source=None, where=None, detail=None):
        with self.assertRaises(dbbkit.InputError) as ctx:
            call()
        e = ctx.exception
        self.assertIsInstance(e, ValueError)
        if source is not None:
            self.assertEqual(e.source, source)
        if where is not None:
            self.assertEqual(e.where, where)
        if detail is not None:
            self.assertRegex(e.detail, detail)
        return e

    def test_design_dict(self):
        with open(PAPER_C) as f:
            raw = json.load(f)
        raw["installations"][3]["direction"] = "sideways"
        self.assertInputError(lambda: dbbkit.Design(raw), "design", "installations[3].direction")
        raw = json.loads(json.dumps(raw).replace('"sideways"', '"radial"'))
        raw["noise"]["half_width_um"] = float("nan")
        self.assertInputError(lambda: dbbkit.Design(raw), "design", "noise.half_width_um", "finite")
        raw["noise"]["half_width_um"] = object()
        self.assertInputError(lambda: dbbkit.Design(raw), "design", "noise.half_width_um", "object")

    def test_design_file(self):
        self.assertInputError(lambda: dbbkit.Design("no/such/design.json"), "no/such/design.json")
        bad = sorted(glob.glob("tests/data/bad/design_*.json"))
        self.assertGreater(len(bad), 5)
        for path in bad:
            e = self.assertInputError(lambda: dbbkit.Design(path), path)
            run = subprocess.run([CLI, "evaluate", "--design", path], capture_output=True, text=True)
            self.assertEqual(run.returncode, 2, path)
            self.assertIn(str(e), run.stderr, path)  # the same message as the command line

    def test_measurements(self):
        d = dbbkit.Design(PAPER_C)
        m = dbbkit.Measurements(DATA_C, d)
        ids = list(m.installation)
        ids[5] = "9z"
        self.assertInputError(lambda: dbbkit.Measurements.from_arrays(d, ids, m.angle_deg, m.reading_um),
                              "measurements", "index 5", "9z")
        self.assertInputError(lambda: dbbkit.Measurements.from_arrays(d, m.installation, m.angle_deg[:-1],
                                                                      m.reading_um), "measurements", "angle_deg")
        self.assertInputError(lambda: dbbkit.Measurements.from_csv("installation,angle_deg,reading_um\n1r,0,x\n", d),
                              "csv", "line 2, column reading_um")
        self.assertInputError(lambda: dbbkit.identify(dbbkit.Design(PAPER_B), m), DATA_C)  # readings of another design

    def test_hostile_inputs(self):
        with open(PAPER_C) as f:
            raw = json.load(f)
        # Text that would end a gnuplot string or a program's comment is refused at the reader,
        # so that displaying a result (_repr_html_) can never run it.
        bad = dict(raw, name="x\n! touch PWNED\nset title 'y")
        self.assertInputError(lambda: dbbkit.Design(bad), "design", "name", "control character")
        # A dict that contains itself, a list nested 50,000 deep: an InputError, not a crash.
        loop = dict(raw)
        loop["assumed"] = loop
        self.assertInputError(lambda: dbbkit.Design(loop), "design", "assumed", "contains itself")
        deep = []
        for _ in range(50000):
            deep = [deep]
        self.assertInputError(lambda: dbbkit.Design(dict(raw, angles_deg=deep)), "design", None, "nested deeper")
        # More readings than a measurement may hold are refused before they are converted.
        class Long:
            def __len__(self):
                return 10**7 + 1
        d = dbbkit.Design(raw)
        self.assertInputError(lambda: dbbkit.Measurements.from_arrays(d, Long(), [0.0], [0.0]),
                              "measurements", "installation", "more than")
        with self.assertRaises(TypeError):
            dbbkit.Measurements.from_arrays(d, [1, 2], [0.0, 1.0], [0.0, 0.0])
        # Complex or two-dimensional arrays are not made real or flat without a word.
        self.assertInputError(lambda: dbbkit.Measurements.from_arrays(
            d, ["1r"], np.array([0.0 + 1j]), [0.0]), "measurements", "angle_deg", "complex")
        self.assertInputError(lambda: dbbkit.Measurements.from_arrays(
            d, ["1r"], [0.0], np.array([[0.0]])), "measurements", "reading_um", "one-dimensional")
        # A str that is not Unicode (a lone surrogate) is refused at its key; a path with the
        # surrogates of undecodable bytes names the file by those bytes.
        self.assertInputError(lambda: dbbkit.Design(dict(raw, name="a\ud800")), "design", "name",
                              "not valid Unicode")
        with tempfile.TemporaryDirectory() as tmp:
            bad = os.path.join(os.fsencode(tmp), b"bad\xff.json")
            with open(PAPER_C, "rb") as f, open(bad, "wb") as g:
                g.write(f.read())
            self.assertEqual(dbbkit.Design(os.fsdecode(bad)).to_dict()["name"], raw["name"])
        # Readings read from a file keep their lines in a later check against another design.
        m = dbbkit.Measurements(DATA_C, d)
        other = dict(raw, installations=[i for i in raw["installations"] if i["id"] != "1a"])
        e = self.assertInputError(lambda: dbbkit.identify(dbbkit.Design(other), m), DATA_C)
        self.assertTrue(e.where.startswith("line "), e.where)

    def test_arguments(self):
        d = dbbkit.Design(PAPER_C)
        m = dbbkit.Measurements(DATA_C, d)
        self.assertInputError(lambda: dbbkit.identify(d, m, coverage=1.5), "argument", "coverage")
        self.assertInputError(lambda: dbbkit.identify(d, m, coverage=float("nan")), "argument", "coverage")
        self.assertInputError(lambda: dbbkit.identify(d, m, mc_threads=100000), "argument", "mc_threads")
        self.assertInputError(lambda: dbbkit.diagnose(d, m, level=0.5), "argument", "level")
        self.assertInputError(lambda: dbbkit.evaluate(d, reference_length_mm=float("inf")), "argument",
                              "reference_length_mm")
        kit = dbbkit.Kit("designs/kits/c-turntable-kit.json")
        self.assertInputError(lambda: dbbkit.optimize(kit, criterion="best"), "criterion", None, "unknown criterion")
        self.assertInputError(lambda: dbbkit.optimize(kit, criterion=""), "criterion", None, "unknown criterion ''")
        self.assertInputError(lambda: dbbkit.optimize(kit, threads=-1), "argument", "threads")
        self.assertInputError(lambda: dbbkit.identify(d, m, tolerances={"format": "dbbkit.tolerances/1",
                                                                        "limits": [{"quantity": "XOC"}]}),
                              "tolerances", None)
        with self.assertRaises(TypeError):
            dbbkit.identify(d, "tests/data/paper/paper_c_turntable.csv")  # a path is not readings


    def test_messages_name_the_keyword_arguments(self):
        # A message names the argument as the caller wrote it (dwell_s, columns, current, ...),
        # never the command line's option (--dwell-s, --columns, --kins, ...).
        d = dbbkit.Design(PAPER_C)
        e = self.assertInputError(lambda: dbbkit.Measurements.from_trace(d, {"1R": DATA_C}), "traces", "'1R'",
                                  r"ids are case-sensitive: '1r'\?\); its installations: 1r, 1t, 1a")
        self.assertNotIn(DATA_C, str(e))
        self.assertInputError(lambda: dbbkit.Measurements.from_trace(d, {"1r": DATA_C}, columns="speed=a"),
                              "columns")
        # Milliseconds from the start, as arrays: said, naming dwell_s and sample_rate_hz.
        t = np.arange(60000.0)
        e = self.assertInputError(lambda: dbbkit.Measurements.from_trace(d, {"1r": (t, np.zeros(t.size))}),
                                  "traces['1r']", None, "the times look like milliseconds")
        self.assertIn("(dwell_s)", e.detail)
        self.assertIn("sample_rate_hz", e.detail)
        self.assertNotIn("--", str(e))
        m = dbbkit.Measurements(DATA_C, d)
        r = dbbkit.identify(d, m)
        # isg takes no current values and no module: the argument is named, and refused (it was
        # ignored without a word).
        e = self.assertInputError(lambda: dbbkit.compensation(r, "isg", current={"x-rot-point": 1.0}), "current",
                                  None, "format='isg' writes the location errors themselves")
        self.assertIn("it takes no current values; current gives", e.detail)
        self.assertNotIn("--", str(e))
        self.assertInputError(lambda: dbbkit.compensation(r, "table", kins="xyzac-trt"), "kins")
        # The readings' file is the source of 'line 2', the argument named in the detail.
        e = self.assertInputError(lambda: dbbkit.identify(d, m, type_a_readings=True), DATA_C, "line 2",
                                  "has no u_a_um and u_a_dof, which type_a_readings needs")
        # A clearance plane below the highest point: refused, naming the argument and the least.
        e = self.assertInputError(lambda: dbbkit.program(dbbkit.Design("designs/c-turntable-kit-optimized.json"),
                                                         "iso", clearance_z_mm=-5), "clearance_z_mm", None,
                                  r"^Z -5 mm is below the lowest safe clearance plane, Z \S+ mm")
        self.assertIn("clearance_margin_mm 50 mm", e.detail)

    def test_measurements_of_another_design_say_whose_they_are(self):
        # They were said to be at an angle that is not a position; now whose they are, by name.
        m = dbbkit.Measurements(DATA_C, dbbkit.Design(PAPER_C))
        e = self.assertInputError(lambda: dbbkit.identify(dbbkit.Design(PAPER_B), m), DATA_C, None,
                                  "^these measurements were read against design 'paper-c-turntable' "
                                  r"\('designs/paper-c-turntable.json'\), not design 'paper-b-head' "
                                  r"\('designs/paper-b-head.json'\): ")
        self.assertTrue(e.where.startswith("line "), e.where)
        self.assertInputError(lambda: dbbkit.diagnose(dbbkit.Design(PAPER_B), m), DATA_C, None,
                              "^these measurements were read against design 'paper-c-turntable'")

    def test_caller_text_is_quoted_escaped_and_short(self):
        # Every text of the caller in a message is quoted with its line breaks escaped and cut;
        # pybind11's TypeErrors are one line naming the types given, never their values.
        d = dbbkit.Design(PAPER_C)
        m = dbbkit.Measurements(DATA_C, d)
        kit = dbbkit.Kit("designs/kits/c-turntable-kit.json")
        for call in (lambda: dbbkit.program(d, "is\no"),
                     lambda: dbbkit.program(d, "iso", sweeps="c\ncw"),
                     lambda: dbbkit.optimize(kit, criterion="wor\nst"),
                     lambda: dbbkit.identify(d, m, effects=["a\nb"]),
                     lambda: dbbkit.identify(d, m, effects="drift[1r],centring.q\nx[1r]"),
                     lambda: dbbkit.program(d, "x" * 5000),
                     lambda: dbbkit.identify(d, m).report("x\n" * 3000)):
            with self.assertRaises(dbbkit.InputError) as ctx:
                call()
            self.assertNotIn("\n", str(ctx.exception))
            self.assertLess(len(str(ctx.exception)), 400, str(ctx.exception)[:200])
        for call in (lambda: dbbkit.program(d, 5),
                     lambda: dbbkit.program(d, "iso", kit="x\n" * 3000),
                     lambda: dbbkit.Measurements.from_csv(["a\nb"], d),
                     lambda: dbbkit.Measurements(DATA_C, "not a design\n" * 1000)):
            with self.assertRaises(TypeError) as ctx:
                call()
            text = str(ctx.exception)
            self.assertNotIn("\n", text)
            self.assertLess(len(text), 1200)
            self.assertIn("incompatible arguments (given: ", text)
        self.assertIn("(given: Design, int)", str(self._type_error(lambda: dbbkit.program(d, 5))))

    def _type_error(self, call):
        with self.assertRaises(TypeError) as ctx:
            call()
        return ctx.exception


class Interaction(InSource):
    def test_gil_is_released_during_a_long_run(self):
        kit = dbbkit.Kit("designs/kits/c-turntable-kit.json")
        done = threading.Event()
        ticks = 0

        def work():
            dbbkit.optimize(kit, threads=1)
            done.set()

        t = threading.Thread(target=work)
        t.start()
        while not done.is_set():
            ticks += 1
            time.sleep(0.001)
        t.join()
        self.assertGreater(ticks, 100)  # the interpreter ran beside the search

    def test_ctrl_c_stops_monte_carlo_and_optimize(self):
        script = (
            "import sys, time, dbbkit\n"
            "d = dbbkit.Design(sys.argv[1])\n"
            "k = dbbkit.Kit(sys.argv[2])\n"
            "print('ready', flush=True)\n"
            "t = time.time()\n"
            "try:\n"
            "    if sys.argv[3] == 'mc':\n"
            "        dbbkit.evaluate(d, monte_carlo=True, mc_digits=4, mc_max_trials=1000000000)\n"
            "    else:\n"
            "        dbbkit.optimize(k, threads=2)\n"
            "    print('finished', time.time() - t)\n"
            "except KeyboardInterrupt:\n"
            "    print('interrupted', time.time() - t)\n")
        for what in ("mc", "optimize"):
            p = subprocess.Popen([sys.executable, "-c", script, PAPER_C, "designs/kits/c-turntable-kit-setup.json",
                                  what], stdout=subprocess.PIPE, text=True, env=os.environ)
            self.assertEqual(p.stdout.readline().strip(), "ready")
            time.sleep(1.0)
            p.send_signal(signal.SIGINT)
            out, _ = p.communicate(timeout=60)
            words = out.split()
            self.assertEqual(words[0], "interrupted", what)
            self.assertLess(float(words[1]), 10.0, what)  # the run would take minutes

    def test_repr_html_is_the_report(self):
        d = dbbkit.Design(PAPER_C)
        r = dbbkit.identify(d, dbbkit.Measurements(DATA_C, d))
        html = r._repr_html_()
        self.assertTrue(html.startswith("<iframe"))
        self.assertIn("<svg", html)
        report = r.report()
        for heading in re.findall(r"<h2[^>]*>([^<]+)</h2>", report):
            self.assertIn(heading.replace("&", "&amp;"), html)
        self.assertIn("## ", r.report("markdown"))


class ReadmeExample(unittest.TestCase):
    """The README's Python example prints what the README shows, and its figures are the CLI's."""

    def test_readme_example(self):
        with open(os.path.join(SOURCE, "README.md")) as f:
            readme = f.read()
        m = re.search(r"<!-- python-example -->\s*```python\n(.*?)```\s*```text\n(.*?)```", readme, re.S)
        self.assertIsNotNone(m, "the README's Python example (marked <!-- python-example -->)")
        code, shown = m.group(1), m.group(2)
        run = subprocess.run([sys.executable, "-c", code], cwd=SOURCE, capture_output=True, text=True,
                             env=os.environ)
        self.assertEqual(run.returncode, 0, run.stderr)
        self.assertEqual(run.stdout, shown)
        # Every figure it prints against the command line's JSON on the same inputs.
        g = cli_json("diagnose", "--design", PAPER_C, "--data", DATA_C)
        r = cli_json("identify", "--design", PAPER_C, "--data", DATA_C)
        lines = run.stdout.splitlines()
        for line, when in zip(lines[:2], ("before", "after")):
            rms, chi2, dof = re.match(r"\w+: +rms (\S+) um, chi2 (\S+) on (\d+) dof", line).groups()
            self.assertEqual(float(rms), float(f"{g[when]['rms_um']:.6g}"))
            self.assertEqual(float(chi2), float(f"{g[when]['chi2']:.6g}"))
            self.assertEqual(int(dof), g[when]["dof"])
        for line, e in zip(lines[2:4], g["added_effects"]):
            self.assertTrue(line.startswith(f"added {e['label']}: "), line)
            for p, v, u in re.findall(r"(\w+) = (\S+) \+- ([0-9.]+)", line):
                self.assertEqual((float(v), float(u)), (round(e["value"][p], 3), round(e["std"][p], 3)))
        rows = [l.split() for l in lines[5:11]]
        self.assertEqual(len(rows), 6)
        for row in rows:
            s = int(float(row[0])) // 20
            before, after = g["errors_before"][s]["value"], g["errors"][s]["value"]
            self.assertEqual([float(x) for x in row[1:]],
                             [round(before["dx"], 3), round(after["dx"], 3), round(before["ey"], 3),
                              round(after["ey"], 3)])
        change = dict(re.findall(r"(\w+) ([0-9.]+)", lines[11].split(":", 1)[1]))
        self.assertEqual({k: float(v) for k, v in change.items()},
                         {k: round(v, 1) for k, v in g["largest_change_of_errors"].items() if v})
        value, u, U, k = re.match(r"dx at 0 deg = (\S+) um, u_c = (\S+) um, U = (\S+) um \(k = (\S+)\)",
                                  lines[12]).groups()
        e0 = r["errors"][0]
        self.assertEqual((float(value), float(u), float(U)),
                         (round(e0["value"]["dx"], 3), round(e0["std"]["dx"], 3), round(e0["U"]["dx"], 3)))
        self.assertEqual(float(k), round(r["budget"]["values"][0]["k"], 2))

if __name__ == "__main__":
    unittest.main()
