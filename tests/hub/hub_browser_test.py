#!/usr/bin/python3
"""(f) A notebook in the browser drives the student's own rig (docs/notebooks.md): a class of
alice and bob with the hub (tests/hub/hub_run.py); in headless Chromium alice opens her page on
the class server, follows its Notebooks link (her class token, once) to the hub, opens a notebook
in her folder and runs its cell, which moves her rig with sirupp.connect(); the move shows in her
panel's state (the class server's API for her rig, and her panel's page in a second tab). With
--screenshot FILE the notebook's page is saved there and her panel's page beside it as
FILE-panel.png (docs/images/notebook-drives-panel.png, notebook-drives-panel-panel.png).

Usage: hub_browser_test.py BIN_DIR SOURCE_DIR [--screenshot FILE]"""

import json
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hub_run import HubRun, Session  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402

GOAL = [-0.5, 0.3, -0.4, 0.3, 0.4, -0.3]
CELL = ("import sirupp\n"
        "rig = sirupp.connect()\n"
        f"rig.move_joints({GOAL!r}, timeout=40)\n"
        "print('moved to', [round(x, 2) for x in rig.q])")


def check(condition, what):
    if not condition:
        raise AssertionError(what)
    print("ok:", what[:160])


def wait(what, predicate, timeout=60):
    deadline = time.time() + timeout
    while time.time() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.25)
    raise AssertionError(f"waited {timeout} s for {what}")


def main(bin_dir, source_dir, screenshot):
    hub = HubRun(bin_dir, source_dir, ["alice", "bob"])
    ok = False
    try:
        hub.start()
        page = hub.cls.addresses["alice"]
        driver = hub.cls.browser(1400, 900)
        driver.get(page)
        link = wait("the Notebooks link on alice's page",
                    lambda: driver.find_elements(By.ID, "class-notebooks"))[0]
        href = link.get_attribute("href")
        check(href.startswith(hub.hub_base + "/hub/login?student=alice&token="),
              f"alice's page links to the hub: {href[:60]}...")
        # A notebook of hers with the cell (written through her server's API with her token).
        driver.get(href)
        wait("alice's notebook server's tree",
             lambda: "/user/alice/tree" in driver.current_url and
             driver.find_elements(By.ID, "notebook_list"), timeout=90)
        check("token=" not in driver.current_url, f"no token in the address: {driver.current_url}")
        session = hub.front("alice")
        hub.sign_in(session)
        token = hub.user_token(session, "alice")
        notebook = {"type": "notebook", "content": {
            "nbformat": 4, "nbformat_minor": 5, "metadata": {
                "kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"}},
            "cells": [{"cell_type": "code", "id": "drive", "metadata": {}, "source": CELL,
                       "outputs": [], "execution_count": None}]}}
        status, _ = Session(hub).api("PUT", "/user/alice/api/contents/notebooks/drive.ipynb",
                                     notebook, token=token)
        check(status in (200, 201), f"the notebook written into alice's folder: {status}")
        driver.get(hub.hub_base + "/user/alice/notebooks/notebooks/drive.ipynb")
        wait("the notebook's kernel", lambda: driver.execute_script(
            "return !!(window.Jupyter && Jupyter.notebook && Jupyter.notebook.kernel && "
            "Jupyter.notebook.kernel.is_connected() && "
            "Jupyter.notebook.kernel.info_reply && Jupyter.notebook.kernel.info_reply.status)"),
             timeout=90)
        driver.execute_script("Jupyter.notebook.execute_all_cells();")
        text = wait("the cell's output", lambda: "".join(
            e.text for e in driver.find_elements(By.CSS_SELECTOR, ".output_area")) or None,
            timeout=90)
        check("moved to" in text, f"the cell ran in the browser: {text.strip()[:120]}")
        status, state = hub.cls.http("GET", "/s/alice/api/state", hub.cls.token("alice"))
        goal_deg = [math.degrees(x) for x in GOAL]
        far = max(abs(a - b) for a, b in zip(state["virtual"]["q"], goal_deg))
        check(status == 200 and far < 2.0,
              f"alice's panel's state shows the arm at the goal: {far:.2f} deg off")
        if screenshot:
            driver.save_screenshot(screenshot)
            print("screenshot:", screenshot)
        # Her panel's page shows it too (its own state stream).
        panel = hub.cls.browser(1400, 900)
        panel.get(page)
        shown = wait("alice's panel's joint readout", lambda: panel.execute_script(
            "return fetch('api/state').then(r => r.json())"), timeout=30)
        far = max(abs(a - b) for a, b in zip(shown["virtual"]["q"], goal_deg))
        check(far < 2.0, f"alice's panel page reads the arm at the goal: {far:.2f} deg off")
        if screenshot:
            time.sleep(4)  # the 3D view drawn
            panel.save_screenshot(screenshot.replace(".png", "-panel.png"))
            print("screenshot:", screenshot.replace(".png", "-panel.png"))
        status, bob = hub.cls.http("GET", "/s/bob/api/state", hub.cls.token("bob"))
        check(status == 503 or "virtual" not in bob or
              min(abs(a - b) for a, b in zip(bob["virtual"]["q"], goal_deg)) > 5,
              "bob's rig did not move")
        ok = True
    finally:
        if not ok:
            print(hub.hub_log()[-6000:])
            print("alice's server:\n" + hub.server_log("alice")[-4000:])
        left = hub.stop()
        if left:
            print("left running (killed):", left)
            ok = False
        else:
            print("ok: nothing of the test is left running")
        if ok:
            hub.clean()
    print("ok" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    if not os.access("/usr/bin/jupyterhub", os.X_OK):
        print("skipped: /usr/bin/jupyterhub is not installed (scripts/install-deps.sh --services)")
        sys.exit(77)
    shot = sys.argv[sys.argv.index("--screenshot") + 1] if "--screenshot" in sys.argv else ""
    sys.exit(main(sys.argv[1], sys.argv[2], shot))
