"""The live view (excite-server --web_listen) in a real browser: headless Chromium
driven by Selenium (Debian's chromium, chromium-driver, python3-selenium) against
the real server while excite-sim explores the pendulum with `rec`. The page must
load, show the running session without a click, draw it with the config's names
and units, round ticks, the region, a colour bar, the learning curve and plan
history the server keeps, flag lengthscales at a bound, follow the window's width
and update as samples arrive; the API must refuse calls without the token.

Run: ctest -R web_live_view (label web), or with EXCITE_SERVER_BIN and
EXCITE_SIM_BIN set: /usr/bin/python3 -m pytest tests/web/test_live_view.py
"""

import json
import math
import os
import pathlib
import re
import signal
import subprocess
import time
import urllib.error
import urllib.request

import pytest
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By

REPO = pathlib.Path(__file__).resolve().parents[2]
TOKEN = "live-view-test-token"
# Sanitizer builds are many times slower: waits are generous, never sleeps.
WAIT_S = 240


def wait_for(what, check, timeout=WAIT_S, interval=0.2):
    deadline = time.monotonic() + timeout
    while True:
        value = check()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(interval)


@pytest.fixture(scope="module")
def exploring(tmp_path_factory):
    """A server with the live view and a plant exploring against it."""
    work = tmp_path_factory.mktemp("live-view")
    env = dict(os.environ, EXCITE_AUTH_TOKEN=TOKEN)
    log_path = work / "server.log"
    log = open(log_path, "w")
    server = subprocess.Popen(
        [os.environ["EXCITE_SERVER_BIN"], "--listen=127.0.0.1:0", f"--data_dir={work}/data",
         "--web_listen=127.0.0.1:0"], stdout=log, stderr=subprocess.STDOUT, env=env)
    sim = None
    try:
        text = wait_for("the server's ports", lambda: (
            lambda t: t if "listening on" in t and "web view on port" in t else None)(
                log_path.read_text()), timeout=60)
        web_port = int(re.search(r"web view on port (\d+)", text).group(1))
        grpc_port = int(re.search(r"listening on 127\.0\.0\.1:(\d+)", text).group(1))
        sim = subprocess.Popen(
            [os.environ["EXCITE_SIM_BIN"], f"--server=127.0.0.1:{grpc_port}",
             f"--config={REPO}/sim/configs/pendulum.textproto", "--strategy=rec",
             "--samples=2000", "--keep_session"],
            stdout=open(work / "sim.log", "w"), stderr=subprocess.STDOUT, env=env)
        yield f"http://127.0.0.1:{web_port}", work, sim
    finally:
        if sim is not None:
            sim.kill()
            sim.wait()
        server.terminate()
        server.wait(timeout=30)
        log.close()


def get(url, token=None):
    request = urllib.request.Request(url)
    if token:
        request.add_header("Authorization", f"Bearer {token}")
    try:
        with urllib.request.urlopen(request, timeout=30) as reply:
            return reply.status, json.loads(reply.read())
    except urllib.error.HTTPError as error:
        return error.code, json.loads(error.read())


@pytest.fixture(scope="module")
def browser():
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for argument in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                     "--window-size=1400,1000"):
        options.add_argument(argument)
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    yield driver
    driver.quit()


def test_the_api_wants_the_token(exploring):
    base, _, _ = exploring
    status, body = get(f"{base}/api/sessions")
    assert status == 401 and body["code"] == "UNAUTHENTICATED", body
    status, body = get(f"{base}/api/sessions", "wrong-token")
    assert status == 401, body
    status, body = get(f"{base}/api/sessions", TOKEN)
    assert status == 200 and "sessions" in body, body
    status, body = get(f"{base}/api/sessions/no-such-session", TOKEN)
    assert status == 404 and body["code"] == "NOT_FOUND", body
    # The page itself holds no data and needs no token.
    with urllib.request.urlopen(base + "/", timeout=30) as reply:
        assert reply.status == 200 and b"excite" in reply.read()


def painted(driver, canvas_id):
    """How many pixels of the canvas are painted (not transparent)."""
    return driver.execute_script(
        "const c = document.getElementById(arguments[0]);"
        "const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
        "let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++; return n;",
        canvas_id)


def number(driver, element_id):
    text = driver.find_element(By.ID, element_id).text
    return int(text) if text.isdigit() else -1


def data(driver, canvas_id, key):
    """A canvas's data-KEY attribute (what the page drew), JSON-decoded."""
    value = driver.find_element(By.ID, canvas_id).get_attribute(f"data-{key}")
    return None if value is None else json.loads(value) if value[:1] in "[{0123456789-" else value


def nice(ticks):
    """Evenly spaced ticks at multiples of 1, 2 or 5 times a power of ten."""
    if len(ticks) < 2:
        return False
    step = ticks[1] - ticks[0]
    mantissa = step / 10 ** math.floor(math.log10(step) + 1e-9)
    return (any(abs(mantissa - m) < 1e-6 for m in (1, 2, 5)) and
            all(abs(b - a - step) < 1e-6 * step for a, b in zip(ticks, ticks[1:])) and
            all(abs(t / step - round(t / step)) < 1e-6 for t in ticks))


def nice_log(ticks):
    return all(abs(t / 10 ** math.floor(math.log10(t) + 1e-9) - round(
        t / 10 ** math.floor(math.log10(t) + 1e-9))) < 1e-6 for t in ticks)


PLOTS = ("plot-curve", "plot-states", "plot-std", "plot-rollout", "plot-objective",
         "plot-samples")


def test_the_page_shows_the_running_session_and_updates(exploring, browser):
    base, work, sim = exploring
    # No session in the address: the page shows the newest one without a click.
    browser.get(f"{base}/#token={TOKEN}")
    session_id = wait_for("a session chosen", lambda: (
        lambda m: m.group(1) if m else None)(re.search(r"#session=([a-z0-9-]+)$",
                                                      browser.current_url)))
    assert TOKEN not in browser.current_url  # it stays in the tab's sessionStorage
    wait_for("the session shown", browser.find_element(By.ID, "session").is_displayed)
    listed = browser.find_element(By.CSS_SELECTOR, f'#sessions li[data-id="{session_id}"]')
    assert "rec" in listed.text and "selected" in listed.get_attribute("class")
    wait_for("samples on the page", lambda: number(browser, "sample-count") > 0)
    wait_for("a plan with its objective",
             lambda: "objective" in browser.find_element(By.ID, "plan-facts").text)
    assert "planned by rec" in browser.find_element(By.ID, "plan-facts").text
    assert "tau = " in browser.find_element(By.ID, "plan-facts").text

    # Updates: the count grows while the plant explores, without a reload.
    first = number(browser, "sample-count")
    wait_for("more samples", lambda: number(browser, "sample-count") > first)
    wait_for("every plot drawn", lambda: all(painted(browser, c) > 2000 for c in PLOTS))
    wait_for("a learning curve with both series", lambda: (
        int(data(browser, "plot-curve", "errors") or 0) >= 3 and
        int(data(browser, "plot-curve", "uncertainty") or 0) >= 2))

    # Names and units from the config on the axes, the selectors and the table.
    assert data(browser, "plot-states", "xlabel") == "theta [rad]"
    assert data(browser, "plot-states", "ylabel") == "theta_dot [rad/s]"
    assert data(browser, "plot-samples", "xlabel") == "seconds since the first sample"
    options = [o.text for o in browser.find_elements(By.CSS_SELECTOR, "#dim-x option")]
    assert options == ["theta [rad]", "theta_dot [rad/s]", "tau [N m]"]
    # Ticks at round numbers on every linear axis, decades on the curve's log axis.
    for canvas in PLOTS:
        assert nice(data(browser, canvas, "xticks")), (canvas, data(browser, canvas, "xticks"))
        if canvas != "plot-curve":
            assert nice(data(browser, canvas, "yticks")), (canvas, data(browser, canvas, "yticks"))
    assert nice_log(data(browser, "plot-curve", "yticks"))
    # Time starts at 0 (no negative padding).
    assert data(browser, "plot-samples", "xrange")[0] == 0
    # The angle is drawn on the circle and the region (one turn, |theta_dot| <= 8) is drawn.
    xr = data(browser, "plot-states", "xrange")
    assert -4 <= xr[0] <= -math.pi and math.pi <= xr[1] <= 4, xr
    assert "region" in data(browser, "plot-states", "region")
    assert "region" in data(browser, "plot-std", "region")
    # The std map: the same axes as the visited states, and a colour bar.
    wait_for("the std map on the states' axes", lambda: (
        data(browser, "plot-std", "xrange") == data(browser, "plot-states", "xrange") and
        data(browser, "plot-std", "yrange") == data(browser, "plot-states", "yrange")))
    low, high = data(browser, "plot-std", "colorbar")
    assert 0 <= low < high
    assert "std of theta [rad]" in browser.find_element(By.ID, "std-range").text
    # The plan history comes from the server, not from what this tab saw.
    # (The page first: plans keep coming, and the page may refresh in between.)
    plans_shown = int(data(browser, "plot-objective", "series"))
    status, hist = get(f"{base}/api/sessions/{session_id}/history", TOKEN)
    assert status == 200 and len(hist["plans"]) >= 1 and len(hist["batch_errors"]) >= 3
    assert 1 <= plans_shown <= len(hist["plans"])

    # The latest plan rolled out: a band that widens from 0 at the plan's first state.
    wait_for("the rollout band", lambda: int(data(browser, "plot-rollout", "series") or 0) > 1)
    band = data(browser, "plot-rollout", "band")
    assert band[0] == 0 and band[-1] > 0, band
    assert data(browser, "plot-rollout", "ylabel") == "theta [rad]"

    # Lengthscales labelled by kernel input (the angle's sine and cosine) and
    # flagged exactly where the server says the fit left them at a bound.
    wait_for("the fitted hyperparameters", lambda: len(
        browser.find_elements(By.CSS_SELECTOR, "#hyperparameters tbody tr")) == 2)
    header = browser.execute_script(
        "return [...document.querySelectorAll('#hyperparameters th')].map(t => t.innerText);")
    assert header[3:7] == ["lengthscale sin theta", "lengthscale cos theta",
                           "lengthscale theta_dot", "lengthscale tau"], header
    # The rows' text in one read: the table is redrawn as the model changes, and an
    # element found before a redraw is stale after it.
    rows = browser.execute_script(
        "return [...document.querySelectorAll('#hyperparameters tbody tr')]"
        ".map(r => r.innerText);")
    assert rows[0].startswith("theta [rad]") and rows[1].startswith("theta_dot"), rows
    # The model changes at every sample (the pendulum refits each time): the plant
    # pauses so that the page and the API show the same model version.
    sim.send_signal(signal.SIGSTOP)
    try:
        def same_version():
            text, flags = browser.execute_script(
                "return [document.getElementById('session-facts').textContent, "
                "[...document.querySelectorAll('#hyperparameters tbody tr')].map("
                "r => [...r.cells].map((c, k) => c.classList.contains('at-bound') && k >= 3 ? "
                "k - 3 : -1).filter(k => k >= 0))];")
            shown = re.search(r"model version (\d+)", text)
            status, now = get(f"{base}/api/sessions/{session_id}", TOKEN)
            if status == 200 and shown and int(shown.group(1)) == int(now["model_version"]):
                return flags, now
            return None
        flagged, session = wait_for("the page at the API's model version", same_version)
    finally:
        sim.send_signal(signal.SIGCONT)
    expected = [[int(k) for k in o.get("lengthscales_at_bound", [])]
                for o in session["outputs"]]
    assert flagged == expected

    # Canvases follow their box (the grid's column) in device pixels.
    size = ("const c = document.getElementById('plot-states');"
            "return [c.width, Math.round(Math.max(200, c.clientWidth) * devicePixelRatio)];")
    width, box = browser.execute_script(size)
    assert width == box
    browser.set_window_size(1000, 1000)  # two columns become one
    wait_for("the canvas resized to its new box", lambda: (
        lambda w: w[0] == w[1] and w[0] != width)(browser.execute_script(size)))
    browser.set_window_size(1400, 1000)

    # What the page shows agrees with the API: the page is read first, since
    # samples keep arriving and the page may refresh between the two reads.
    shown = number(browser, "sample-count")
    status, session = get(f"{base}/api/sessions/{session_id}", TOKEN)
    assert status == 200 and 0 < shown <= int(session["sample_count"])
    assert session["config"]["strategy"] == "STRATEGY_REC"
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert not errors, errors
    wait_for("the plots drawn again", lambda: all(painted(browser, c) > 2000 for c in PLOTS))
    browser.save_screenshot(str(work / "live-view.png"))
    if os.environ.get("EXCITE_SCREENSHOT"):
        browser.save_screenshot(os.environ["EXCITE_SCREENSHOT"])


def test_without_the_token_the_page_asks_for_it(exploring, browser):
    base, _, _ = exploring
    browser.get(f"{base}/")
    browser.execute_script("sessionStorage.clear()")
    browser.refresh()
    form = browser.find_element(By.ID, "token-form")
    wait_for("the token prompt", form.is_displayed)
    assert not browser.find_elements(By.CSS_SELECTOR, "#sessions li[data-id]")
    browser.find_element(By.ID, "token-input").send_keys(TOKEN)
    browser.find_element(By.CSS_SELECTOR, "#token-form button").click()
    wait_for("the list after the token", lambda: browser.find_elements(
        By.CSS_SELECTOR, "#sessions li[data-id]"))
    assert not form.is_displayed()


def test_with_tls_the_view_is_https_only(tmp_path):
    """With --tls_cert the page and the API are served over HTTPS (the API's
    certificate; deploy/k8s/make-secrets.sh makes one for 127.0.0.1), and a token
    is required as before."""
    import socket
    import ssl
    secrets = tmp_path / "secrets"
    subprocess.run(["bash", str(REPO / "deploy/k8s/make-secrets.sh"), "default", str(secrets)],
                   check=True, capture_output=True)
    log_path = tmp_path / "server.log"
    with open(log_path, "w") as log:
        server = subprocess.Popen(
            [os.environ["EXCITE_SERVER_BIN"], "--listen=127.0.0.1:0",
             f"--data_dir={tmp_path}/data", "--web_listen=127.0.0.1:0",
             f"--tls_cert={secrets}/tls.crt", f"--tls_key={secrets}/tls.key",
             f"--auth_token_file={secrets}/token"], stdout=log, stderr=subprocess.STDOUT)
        try:
            text = wait_for("the web port", lambda: (lambda t: t if "web view on port" in t
                                                     else None)(log_path.read_text()), 60)
            port = int(re.search(r"web view on port (\d+)", text).group(1))
            assert f"https://127.0.0.1:{port}/" in text
            token = (secrets / "token").read_text().strip()
            context = ssl.create_default_context(cafile=str(secrets / "ca.crt"))
            request = urllib.request.Request(f"https://127.0.0.1:{port}/api/sessions",
                                             headers={"Authorization": f"Bearer {token}"})
            with urllib.request.urlopen(request, context=context, timeout=30) as reply:
                assert reply.status == 200 and json.loads(reply.read()) == {
                    "sessions": [], "next_page_token": ""}
            with pytest.raises(urllib.error.HTTPError) as refused:
                urllib.request.urlopen(f"https://127.0.0.1:{port}/api/sessions",
                                       context=context, timeout=30)
            assert refused.value.code == 401
            # Plain HTTP gets no page: the connection is not an HTTP one.
            with socket.create_connection(("127.0.0.1", port), timeout=10) as plain:
                plain.sendall(b"GET / HTTP/1.0\r\n\r\n")
                assert b"<html" not in plain.recv(4096)
        finally:
            server.terminate()
            server.wait(timeout=30)


def test_a_token_without_tls_is_refused_off_loopback(tmp_path):
    started = subprocess.run(
        [os.environ["EXCITE_SERVER_BIN"], "--listen=127.0.0.1:0", f"--data_dir={tmp_path}/data",
         "--web_listen=0.0.0.0:0"], capture_output=True, text=True, timeout=60,
        env=dict(os.environ, EXCITE_AUTH_TOKEN=TOKEN))
    assert started.returncode != 0
    assert "a token without TLS is refused off loopback" in started.stderr, started.stderr
