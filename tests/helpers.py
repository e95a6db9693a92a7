"""Small helpers shared by several test modules (imported as ``from helpers import ...``;
pytest puts tests/ on sys.path)."""

import base64
import io
import json
import os
import re
import select
import subprocess
import sys
import time

import numpy as np


def wait_until(predicate, timeout_s=5.0, what="condition"):
    """Poll ``predicate()`` every 10 ms; AssertionError naming ``what`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.01)


def wait_on_rig(rig, predicate, timeout_s=10.0, what="condition", step_s=0.05):
    """Let time pass on the rig clock (reading frames, ``step_s`` at a time) until
    ``predicate()``; AssertionError naming ``what`` after ``timeout_s`` s of rig time. On a
    bench on virtual time this is the same run whatever the machine's load."""
    t_end = rig.now() + timeout_s
    while not predicate():
        if rig.now() > t_end:
            raise AssertionError(f"timed out after {timeout_s} s of rig time waiting for {what}")
        rig.wait(step_s)


def fd_jacobian(f, x, h=1e-6):
    """Central differences ``(f(x + h e_j) - f(x - h e_j)) / 2h`` for every unit vector e_j of
    the *last* axis of ``x``: shape ``f(x).shape + (n,)``, so ``J[..., i, j] = d f_i / d x_j``.

    The one finite-difference helper of the test suite: every analytic derivative (energy,
    cables, sensitivities, network and IK Jacobians) is checked against it. Leading axes
    of ``x`` are a batch: all rows move together, which gives the per-row Jacobians of a
    row-wise function (a batched network). ``x`` itself is never modified."""
    x = np.asarray(x, dtype=float)
    cols = []
    for j in range(x.shape[-1]):
        d = np.zeros(x.shape[-1])
        d[j] = h
        cols.append((np.asarray(f(x + d), dtype=float) - np.asarray(f(x - d), dtype=float)) / (2 * h))
    return np.stack(cols, axis=-1)


def fd_derivative(f, x, h=1e-6):
    """Central differences of an elementwise function: ``(f(x + h) - f(x - h)) / 2h``."""
    x = np.asarray(x, dtype=float)
    return (np.asarray(f(x + h), dtype=float) - np.asarray(f(x - h), dtype=float)) / (2 * h)


def fd_parameter_jacobian(model, u, h=1e-6):
    """Central-difference d y / d theta (N * n_y, n_params) of an MLP, parameters restored."""
    theta = model.get_params()

    def predict(th):
        model.set_params(th)
        return model.predict(u).ravel()

    try:
        return fd_jacobian(predict, theta, h)
    finally:
        model.set_params(theta)


def subprocess_env() -> dict:
    """The environment for a ``python -m lab`` subprocess: this one, one BLAS thread, no PYTHONPATH."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    return env


def default_sigint() -> None:
    """``preexec_fn`` for a subprocess a test interrupts with SIGINT: a suite started in the
    background (``nohup scripts/test &``) passes SIGINT on as ignored, and Python then installs
    no KeyboardInterrupt handler, so the child would never see the Ctrl-C the test sends."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


#: Time limits that turn a hang into a named failure. A notebook cell gets CELL_TIMEOUT_S
#: (papermill's execution_timeout: the error names the cell); a whole chapter's test gets
#: NOTEBOOK_TEST_TIMEOUT_S (pytest-timeout, names the test). Every other test has pytest.ini's
#: ``timeout``. The slowest quick-mode cell takes about a minute on an idle 2-core machine, a
#: whole quick chapter about 1.5 min; the limits leave 5-10x for a loaded machine.
CELL_TIMEOUT_S = 600
NOTEBOOK_TEST_TIMEOUT_S = 1800


def assert_reruns(result, rerun):
    """``result``, a failed grade, names the call that runs its case alone (``case=k``) and
    ``rerun(k)`` (its checker called again with ``case=k``) fails with the very same words:
    the case is the same case, and the message is the same message. Returns ``result``."""
    assert result.status == "failed" and result.case is not None, result
    first = result.details.splitlines()[0]
    assert re.fullmatch(rf"To rerun it: check_\w+\(.+, case={result.case}\)", first), result.details
    assert "Its inputs, as code" in result.details, result.details
    again = rerun(result.case)
    assert (again.status, again.case, str(again)) == (result.status, result.case, str(result))
    assert again.details == result.details
    return result


def output_text(cell) -> str:
    """Everything a cell showed as text: its streams and the plain-text form of its
    displays and results (a grader's result, a computed statement)."""
    parts = []
    for o in cell.get("outputs", []):
        parts.append("".join(o.get("text", "")))
        parts.append("".join(o.get("data", {}).get("text/plain", "")))
    return "".join(parts)


def execute_notebook(notebook, out, **kwargs):
    """papermill.execute_notebook with the per-cell limit and no progress bar."""
    import papermill

    kwargs.setdefault("execution_timeout", CELL_TIMEOUT_S)
    kwargs.setdefault("progress_bar", False)
    return papermill.execute_notebook(str(notebook), str(out), **kwargs)


class DevToolsPage:
    """One page of a headless Chromium, driven over the DevTools protocol on a pipe
    (``--remote-debugging-pipe``: no port, so it works inside ``unshare -n`` too), for
    browser tests that wait for a rendered state instead of sleeping: ``wait_for`` polls
    the page's own state, ``screenshot`` lets the page draw two frames first.

    ``command``: how to start Chromium (its flags included); ``profile_dir``: a fresh
    directory for its profile and log; the viewport is ``width`` x ``height`` px.
    """

    def __init__(self, command, profile_dir, width=800, height=600, timeout_s=120.0):
        import fcntl

        self.timeout_s, self._buf, self._id, self._events = timeout_s, b"", 0, []
        os.makedirs(profile_dir, exist_ok=True)
        self.log = os.path.join(profile_dir, "chromium.log")
        # Chromium reads commands on fd 3 and answers on fd 4; a small trampoline puts the
        # pipe ends there (fds >= 10 here, so that no dup2 overwrites the other end).
        to_r, to_w = os.pipe()
        from_r, from_w = os.pipe()
        ends = [fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 10) for fd in (to_r, from_w)]
        for fd in (to_r, from_w):
            os.close(fd)
        trampoline = (
            f"import os, sys; os.dup2({ends[0]}, 3); os.dup2({ends[1]}, 4); "
            f"os.close({ends[0]}); os.close({ends[1]}); os.execvp(sys.argv[1], sys.argv[1:])"
        )
        argv = [sys.executable, "-c", trampoline, *command, "--remote-debugging-pipe"]
        with open(self.log, "wb") as log:
            self.proc = subprocess.Popen(
                [*argv, f"--user-data-dir={profile_dir}", "about:blank"],
                pass_fds=ends,
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=log,
            )
        for fd in ends:
            os.close(fd)
        self._w, self._r = to_w, from_r
        try:
            (target,) = [t for t in self._call("Target.getTargets")["targetInfos"] if t["type"] == "page"]
            self._session = self._call("Target.attachToTarget", targetId=target["targetId"], flatten=True)["sessionId"]
            self.call("Page.enable")
            self.call(
                "Emulation.setDeviceMetricsOverride", width=width, height=height, deviceScaleFactor=1, mobile=False
            )
        except BaseException:
            self.close()
            raise

    def _read(self) -> dict:
        deadline = time.monotonic() + self.timeout_s
        while b"\0" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._r], [], [], left)[0]:
                raise AssertionError(f"chromium sent nothing for {self.timeout_s} s; its log:\n{self._log_tail()}")
            chunk = os.read(self._r, 1 << 20)
            if not chunk:
                raise AssertionError(f"chromium closed the DevTools pipe; its log:\n{self._log_tail()}")
            self._buf += chunk
        message, self._buf = self._buf.split(b"\0", 1)
        return json.loads(message)

    def _log_tail(self) -> str:
        with open(self.log, errors="replace") as f:
            return f.read()[-3000:]

    def _call(self, method, session=None, **params) -> dict:
        self._id += 1
        message = {"id": self._id, "method": method, "params": params} | ({"sessionId": session} if session else {})
        os.write(self._w, json.dumps(message).encode() + b"\0")
        while (reply := self._read()).get("id") != self._id:
            self._events.append(reply)
        if "error" in reply:
            raise AssertionError(f"DevTools {method} failed: {reply['error']}")
        return reply["result"]

    def call(self, method, **params) -> dict:
        """A DevTools command on the page, e.g. ``call("Page.navigate", url=...)``."""
        return self._call(method, self._session, **params)

    def evaluate(self, expression: str, await_promise: bool = False):
        """The value of a JavaScript expression in the page (awaited if a promise)."""
        r = self.call("Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=await_promise)
        if "exceptionDetails" in r:
            raise AssertionError(f"{expression!r} raised in the page: {r['exceptionDetails']}")
        return r["result"].get("value")

    def wait_for(self, expression: str, timeout_s: float, what: str) -> None:
        """Poll ``expression`` until it is truthy; AssertionError naming ``what`` after ``timeout_s``."""
        wait_until(lambda: self.evaluate(expression), timeout_s, what)

    def navigate(self, url: str) -> None:
        self.call("Page.navigate", url=url)

    def screenshot(self) -> np.ndarray:
        """The viewport (height, width, 3) RGB ints, after the page has drawn two more frames."""
        from PIL import Image

        self.evaluate("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(() => r(true))))", True)
        png = base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)

    def close(self) -> None:
        try:
            if self.proc.poll() is None:
                self._call("Browser.close")
            self.proc.wait(timeout=30)
        except (AssertionError, OSError, subprocess.TimeoutExpired):
            self.proc.kill()
            self.proc.wait()
        finally:
            for fd in (self._w, self._r):
                try:
                    os.close(fd)
                except OSError:
                    pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
