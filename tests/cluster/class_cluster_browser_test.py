"""One student's page through the class server's proxy to a rig that runs as a Slurm job, in
headless Chromium (Selenium, Debian's python3-selenium): the page first says it waits for the
cluster, reloads itself when the job's rig is ready, then shows the live arm through the proxy
and moves it; no console errors once the rig runs.

Run: tests/cluster/with_cluster.sh /usr/bin/python3 -m pytest -q tests/cluster/class_cluster_browser_test.py
(env SIRUPP_BIN_DIR: the build's bin/).
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tests", "class"))
sys.path.insert(0, os.path.join(ROOT, "tests", "panel"))
from class_cluster_test import finish, start_class, wait_for  # noqa: E402
from panel_rig import severe_errors  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402


def js(d, code):
    return d.execute_script(code)


def test_a_students_page_through_the_proxy_in_chromium():
    run = start_class(["alice"])
    try:
        d = run.browser()
        d.get(run.addresses["alice"])
        # The page loads at once; the bar says where the rig is until the job's rig is ready.
        wait_for("the class bar", 20, lambda: "Class" in d.find_element(By.ID, "class-status").text)
        wait_for("the panel live through the proxy", 90, lambda: js(
            d, "return window.panelReady && model !== null && window.panelStats"
               " && window.panelStats.received > 5"))
        assert "token=" not in d.current_url, d.current_url
        wait_for("the bar says running", 10, lambda: "running" in d.find_element(
            By.ID, "class-status").text)
        severe_errors(d)  # what the page logged while it waited (503s) is left behind here
        js(d, "document.getElementById('lock-name').value = 'alice'")
        d.find_element(By.ID, "take-control").click()
        wait_for("alice holds control", 10,
                 lambda: "you hold control" in d.find_element(By.ID, "lock-state").text)
        js(d, """const s = document.querySelector('#joint-2 .slider');
                 s.value = 30; s.dispatchEvent(new Event('input'));
                 s.dispatchEvent(new Event('change'));""")
        wait_for("joint 2 at 30 deg on the page, through the proxy", 30, lambda: abs(
            (js(d, "return latest && latest.virtual ? latest.virtual.q[1] : null") or 0) - 30) < 1)
        received = js(d, "return window.panelStats.received")
        wait_for("the stream goes on", 5,
                 lambda: js(d, "return window.panelStats.received") > received + 10)
        errors = severe_errors(d)
        assert not errors, "SEVERE console messages: %s" % errors
    finally:
        finish(run)
