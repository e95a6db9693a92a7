"""Make this folder's notebooks: a small chapter's student edition as saved by a real JupyterLab.

    PYTHONPATH=$PWD .venv/bin/python tests/data/jupyterlab_saves/make_fixtures.py [OUT_DIR]

``source.json`` is a chapter in the course's format (a parameters cell, an exercise, its
solution, a grader). The script writes its student edition (``written.json``, as
:func:`lab.course.edition.build_student_edition` writes it), starts JupyterLab on loopback
with a token in a temporary folder, opens the edition in headless Chromium and drives
JupyterLab's own frontend over the DevTools protocol (``--LabApp.expose_app_in_browser``):

- ``opened.json``: opened and left alone until JupyterLab's autosave (its interval set to
  2 s) saved it: the kernel's ``language_info`` is all it adds;
- ``ran.json``: then every cell run (Run All) and saved (``docmanager:save``): outputs and
  execution counts of the given cells;
- ``edited.json``: then the solution cell's source changed in the frontend's model (what
  typing does) and saved.

Every save goes through JupyterLab's document manager to the server's Contents API
(``PUT /api/contents/PATH``), the way a student's saves do. tests/test_course_edition.py
checks the edition's verdict on each. The notebooks are stored as ``.json`` (their content
is ``.ipynb`` JSON) so that ``ruff format``, which formats ``.ipynb`` files, leaves them
byte for byte as JupyterLab saved them. With ``OUT_DIR`` the notebooks go there instead
(a test does so, to check today's JupyterLab against the committed saves).
"""

import json
import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
import uuid
from pathlib import Path

import websocket  # websocket-client, a dependency of jupyter_server

from lab.course.edition import edition_text

HERE = Path(__file__).resolve().parent
CHROMIUM = "/usr/bin/chromium"
NAME = "01_doubling.ipynb"


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait(what, check, timeout=240.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = check()
        if value:
            return value
        time.sleep(0.5)
    raise SystemExit(f"timed out waiting for {what}")


class Page:
    """One page of headless Chromium, driven over the DevTools protocol."""

    def __init__(self, ws_url: str):
        self.ws, self.n = websocket.create_connection(ws_url, timeout=60), 0

    def js(self, expr: str):
        self.n += 1
        params = {"expression": expr, "awaitPromise": True, "returnByValue": True}
        self.ws.send(json.dumps({"id": self.n, "method": "Runtime.evaluate", "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self.n:
                result = msg["result"]
                if "exceptionDetails" in result:
                    raise RuntimeError(json.dumps(result["exceptionDetails"])[:2000])
                return result["result"].get("value")


def main(out: Path = HERE) -> None:
    written, _ = edition_text(HERE / "source.json", "../")
    (out / "written.json").write_text(written)
    tmp = Path(tempfile.mkdtemp(prefix="jlab-fixture-"))
    root, token, port, cdp = tmp / "root", uuid.uuid4().hex, _port(), _port()
    root.mkdir()
    (root / NAME).write_text(written)
    settings = tmp / "settings" / "@jupyterlab" / "docmanager-extension"
    settings.mkdir(parents=True)
    (settings / "plugin.jupyterlab-settings").write_text(json.dumps({"autosaveInterval": 2}))
    env = {**os.environ, "JUPYTER_CONFIG_DIR": str(tmp / "config"), "JUPYTER_RUNTIME_DIR": str(tmp / "runtime"),
           "JUPYTERLAB_WORKSPACES_DIR": str(tmp / "workspaces")}  # fmt: skip
    server = subprocess.Popen(
        [sys.executable, "-m", "jupyterlab", "--no-browser", f"--port={port}", "--ServerApp.ip=127.0.0.1",
         f"--IdentityProvider.token={token}", f"--ServerApp.root_dir={root}", "--allow-root",
         f"--LabApp.user_settings_dir={tmp / 'settings'}", "--LabApp.expose_app_in_browser=True",
         "--LabServerApp.news_url=", "--LabApp.extension_manager=readonly",
         "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate"],
        env=env, stdout=subprocess.DEVNULL, stderr=open(tmp / "server.log", "w"),
    )  # fmt: skip
    base = f"http://127.0.0.1:{port}"
    browser = None
    try:
        _wait("the server", lambda: _get(f"{base}/api/status?token={token}"))
        browser = subprocess.Popen(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-extensions",
             "--disable-background-networking", "--proxy-server=127.0.0.1:9", "--proxy-bypass-list=127.0.0.1",
             f"--user-data-dir={tmp / 'profile'}", f"--remote-debugging-port={cdp}", "--window-size=1200,900",
             f"{base}/lab/tree/{NAME}?token={token}"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        pages = _wait("chromium", lambda: _get(f"http://127.0.0.1:{cdp}/json/list"))
        page = Page(next(p for p in json.loads(pages) if p["type"] == "page")["webSocketDebuggerUrl"])
        _wait("JupyterLab's notebook", lambda: page.js(
            "!!(window.jupyterapp && jupyterapp.shell.currentWidget && jupyterapp.shell.currentWidget.content"
            " && jupyterapp.shell.currentWidget.context.isReady)"))  # fmt: skip
        _wait("the autosave", lambda: "version" in json.loads((root / NAME).read_text())["metadata"]
              .get("language_info", {}))  # fmt: skip
        (out / "opened.json").write_text((root / NAME).read_text())
        page.js("jupyterapp.commands.execute('notebook:run-all-cells')")
        _wait("the cells to run", lambda: page.js(
            "jupyterapp.shell.currentWidget.content.widgets.every(c => c.model.type !== 'code'"
            " || (c.model.executionCount !== null && c.model.sharedModel.execution_state !== 'running'))"))  # fmt: skip
        page.js("jupyterapp.commands.execute('docmanager:save')")
        _wait("the save", lambda: '"execution_count": 4' in (root / NAME).read_text())
        (out / "ran.json").write_text((root / NAME).read_text())
        page.js(
            "(() => { const cells = jupyterapp.shell.currentWidget.content.model.sharedModel.cells;"
            " const c = cells.find(c => c.source.includes('NotImplementedError'));"
            " c.setSource(c.source.replace(/raise NotImplementedError.*/, 'return 2 * x'));"
            " return jupyterapp.commands.execute('docmanager:save'); })()"
        )
        _wait("the edited save", lambda: "return 2 * x" in (root / NAME).read_text())
        (out / "edited.json").write_text((root / NAME).read_text())
    finally:
        for proc in (browser, server):
            if proc is not None:
                proc.terminate()
                proc.wait(timeout=30)
    print(f"wrote {out}/{{written,opened,ran,edited}}.json (JupyterLab's log: {tmp / 'server.log'})")


def _get(url: str):
    try:
        with urllib.request.urlopen(url, timeout=5) as r:
            return r.read().decode()
    except OSError:
        return None


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE)
