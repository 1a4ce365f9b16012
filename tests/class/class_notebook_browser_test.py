#!/usr/bin/python3
"""Notebook assignments in real browsers (headless Chromium + Selenium): alice opens My
assignments on her page, submits a notebook whose fk ignores the DH offsets through the file
chooser, and her page shows 3 of 6 points with the hidden table's test failed and its message,
and her notebook's output; the teacher's page shows her score and each test, the output, and
links grades.csv. Usage: class_notebook_browser_test.py BIN_DIR SOURCE_DIR [SHOTS_DIR]."""

import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "python"))
from class_run import ClassRun  # noqa: E402
from panel_rig import severe_errors, wait_for  # noqa: E402
import fk3_notebooks as fk3  # noqa: E402

from selenium.webdriver.common.by import By  # noqa: E402

BIN, SRC = sys.argv[1], os.path.abspath(sys.argv[2])
SHOTS = sys.argv[3] if len(sys.argv) > 3 else None

extra = ("notebooks:\n"
         f"  folder: {SRC}/notebooks\n"
         "  assignments:\n"
         f"    - {{name: fk3, notebook: {fk3.ASSIGNMENT}, tests: {fk3.HIDDEN}, timeout_s: 60}}\n")
run = ClassRun(BIN, SRC, ["alice", "bob"], extra_yaml=extra).start()
ok = False
try:
    buggy = fk3.write(fk3.NO_OFFSET, os.path.join(run.work, "alice_fk3.ipynb"))
    a = run.browser()
    a.get(run.addresses["alice"])
    wait_for("alice's bar", lambda: a.find_elements(By.ID, "assignments-toggle"), 30)
    a.find_element(By.ID, "assignments-toggle").click()
    wait_for("the fk3 assignment", lambda: a.find_elements(By.CSS_SELECTOR, "section.assignment"), 10)
    section = a.find_element(By.CSS_SELECTOR, "section.assignment")
    assert "test_a_table_you_have_not_seen (3)" in section.text, section.text
    section.find_element(By.CSS_SELECTOR, ".assignment-file").send_keys(buggy)
    section.find_element(By.CSS_SELECTOR, ".assignment-upload").click()
    wait_for("alice's score on her page",
             lambda: "3 of 6 points" in a.find_element(By.ID, "assignments-panel").text, 90)
    text = a.find_element(By.ID, "assignments-panel").text
    print("alice's page:", " | ".join(line for line in text.splitlines() if "test_" in line))
    assert "fk differs from sirupp.Model" in text, text
    a.find_element(By.CSS_SELECTOR, "#assignments-panel details summary").click()
    assert "visible tests passed" in a.find_element(By.CSS_SELECTOR, "#assignments-panel pre").text
    if SHOTS:
        a.save_screenshot(os.path.join(SHOTS, "notebook-assignment-student.png"))
    assert not severe_errors(a), severe_errors(a)

    t = run.browser()
    t.get(run.addresses["teacher"])
    wait_for("alice's row on the teacher's page",
             lambda: "3 / 6" in t.find_element(By.ID, "notebook-grades").text, 20)
    row = t.find_element(By.ID, "notebook-alice").text
    print("teacher's page:", row.replace("\n", " | "))
    assert "test_a_table_you_have_not_seen 0/3: fk differs" in row, row
    assert "no submission" in t.find_element(By.ID, "notebook-bob").text
    t.find_element(By.CSS_SELECTOR, "#notebook-alice details summary").click()
    wait_for("alice's output on the teacher's page", lambda: "visible tests passed" in
             t.find_element(By.CSS_SELECTOR, "#notebook-alice pre").text, 10)
    time.sleep(5.5)  # one refresh later the opened output is still there
    assert "visible tests passed" in t.find_element(By.CSS_SELECTOR, "#notebook-alice pre").text
    assert t.find_element(By.ID, "grades-csv").get_attribute("href").endswith("/teacher/grades.csv")
    if SHOTS:
        t.save_screenshot(os.path.join(SHOTS, "notebook-assignment-teacher.png"))
    assert not severe_errors(t), severe_errors(t)
    ok = True
finally:
    run.stop()
    if ok:
        run.clean()
    else:
        print("server log:\n" + run.server_log())
print("ok" if ok else "FAIL")
sys.exit(0 if ok else 1)
