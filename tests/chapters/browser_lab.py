"""JupyterLab in headless Chromium, driven through chromium-driver by selenium.

The machinery of the browser tests: start a JupyterLab server on 127.0.0.1
(a free port, a random token, a temporary root folder, its own settings and
runtime folders, no browser of its own), open a notebook in Debian's Chromium,
run it, execute code in its kernel, and read what the page shows. Everything
waits on conditions with a deadline and is shut down by the context managers,
whatever happens in between.

Nothing here is specific to tissuefem: what a page paints is counted by the
tests themselves (the view's canvas carries its own counter).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

INSTALL_HINT = "apt-get install chromium chromium-driver (Debian), then pip install selenium"

#: Chromium's flags: headless, as root, and no network attempts beyond the page itself
CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
    "--disable-renderer-backgrounding",
    "--disable-background-timer-throttling",
    "--disable-backgrounding-occluded-windows",
    "--force-device-scale-factor=1",
    "--window-size=1280,1400",
)


def browser_missing() -> str | None:
    """Why the browser test cannot run here (a sentence naming what to install), or ``None``."""
    missing = [name for name in ("chromium", "chromedriver") if shutil.which(name) is None]
    if missing:
        return f"{' and '.join(missing)} not found: {INSTALL_HINT}"
    for module, hint in (("selenium", "pip install selenium (in the 'test' extra)"),
                         ("jupyterlab", "pip install jupyterlab")):
        try:
            __import__(module)
        except ImportError:
            return f"{module} is not installed: {hint}"
    return None


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(condition, timeout, what, interval=0.1):
    """Call ``condition()`` until it returns something truthy (returned); ``TimeoutError`` after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise TimeoutError(f"waited {timeout:.0f} s for {what}")
        time.sleep(interval)


class JupyterLab:
    """A JupyterLab server on 127.0.0.1 with its own folders under ``workdir``; a context manager.

    The notebooks to open go into ``workdir / "notebooks"`` (the server's root).
    The server's log is kept in ``workdir / "jupyterlab.log"`` and quoted when
    it fails to start. The server is as installed, with tissuefem's extension :mod:`tissuefem.surgery.nodelay`;
    ``nagle=True`` disables it (the kernels' websockets as Jupyter Server leaves them, with Nagle's algorithm).
    """

    def __init__(self, workdir, startup_timeout=90.0, nagle=False):
        self.workdir = Path(workdir)
        self.root = self.workdir / "notebooks"
        self.port = free_port()
        self.token = os.urandom(16).hex()
        self.startup_timeout = startup_timeout
        self.nagle = bool(nagle)
        self.process = None
        self._log = None

    @property
    def base_url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def url(self, path="lab") -> str:
        return f"{self.base_url}/{path}?token={self.token}"

    def _settings(self) -> Path:
        """User settings: no news feed, no notebook windowing (every cell stays in the page)."""
        settings = self.workdir / "lab-settings"
        files = {
            "@jupyterlab/apputils-extension/notification.jupyterlab-settings": {"fetchNews": "false",
                                                                                "checkForUpdates": False},
            "@jupyterlab/notebook-extension/tracker.jupyterlab-settings": {"windowingMode": "none"},
        }
        for name, content in files.items():
            path = settings / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(content))
        return settings

    def __enter__(self):
        self.root.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ)
        for var, sub in (("JUPYTER_CONFIG_DIR", "config"), ("JUPYTER_RUNTIME_DIR", "runtime"),
                         ("IPYTHONDIR", "ipython")):
            env[var] = str(self.workdir / sub)
        env["MPLBACKEND"] = "agg"  # the notebook chooses its own backend; nothing may open a window
        if self.nagle:  # the lab's own configuration folder comes before the environment's
            config = self.workdir / "config"
            config.mkdir(parents=True, exist_ok=True)
            off = {"ServerApp": {"jpserver_extensions": {"tissuefem.surgery.nodelay": False}}}
            (config / "jupyter_server_config.json").write_text(json.dumps(off))
        settings = self._settings()
        cmd = [
            sys.executable, "-m", "jupyterlab",
            "--no-browser",
            "--ServerApp.ip=127.0.0.1",
            f"--ServerApp.port={self.port}",
            "--ServerApp.port_retries=0",
            f"--IdentityProvider.token={self.token}",
            f"--ServerApp.root_dir={self.root}",
            "--ServerApp.open_browser=False",
            "--ServerApp.allow_root=True",  # CI runs as root
            "--ServerApp.disable_check_xsrf=False",
            "--LabApp.expose_app_in_browser=True",
            "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate",
            "--LabApp.extension_manager=readonly",
            f"--LabApp.user_settings_dir={settings}",
            f"--LabApp.workspaces_dir={self.workdir / 'workspaces'}",
        ]
        self._log = open(self.workdir / "jupyterlab.log", "wb")
        self.process = subprocess.Popen(cmd, cwd=self.root, env=env, stdout=self._log, stderr=subprocess.STDOUT,
                                        stdin=subprocess.DEVNULL, start_new_session=True)
        try:
            wait_for(self._ready, self.startup_timeout, "JupyterLab to answer on its port", interval=0.25)
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def _ready(self) -> bool:
        if self.process.poll() is not None:
            raise RuntimeError(f"JupyterLab exited with {self.process.returncode}:\n{self.log_tail()}")
        try:
            with urllib.request.urlopen(self.url("api/status"), timeout=2) as r:
                return r.status == 200
        except (urllib.error.URLError, OSError):
            return False

    def log_tail(self, n=40) -> str:
        try:
            lines = (self.workdir / "jupyterlab.log").read_text(errors="replace").splitlines()
        except OSError:
            return ""
        return "\n".join(lines[-n:])

    def __exit__(self, *exc):
        p = self.process
        if p is not None and p.poll() is None:
            # the server and its kernels are one process group of ours: ask nicely, then insist
            try:
                request = urllib.request.Request(self.url("api/shutdown"), method="POST")
                urllib.request.urlopen(request, timeout=5).close()
                p.wait(timeout=15)
            except (urllib.error.URLError, OSError, subprocess.TimeoutExpired):
                pass
            for sig, wait in ((signal.SIGTERM, 10), (signal.SIGKILL, 10)):
                if p.poll() is not None:
                    break
                try:
                    os.killpg(p.pid, sig)
                except ProcessLookupError:
                    break
                try:
                    p.wait(timeout=wait)
                except subprocess.TimeoutExpired:
                    pass
        if p is not None:
            try:  # kernels left behind in the group (the server is gone)
                os.killpg(p.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        if self._log is not None:
            self._log.close()
        return False


def descendants(pid) -> list[int]:
    """``pid`` and every process under it (Linux ``/proc``; empty elsewhere)."""
    children = {}
    for entry in Path("/proc").glob("[0-9]*"):
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        children.setdefault(int(fields[1]), []).append(int(entry.name))
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo.extend(children.get(p, []))
    return out


def cpu_seconds(pids) -> float:
    """User + system CPU seconds used so far by the processes ``pids`` (those that still exist)."""
    tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    total = 0
    for pid in pids:
        try:
            fields = (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        total += int(fields[11]) + int(fields[12])  # utime, stime
    return total / tick


def start_chromium(workdir):
    """A selenium driver for Debian's Chromium (headless, a fresh profile under ``workdir``)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = shutil.which("chromium")
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    profile = Path(workdir) / "chromium-profile"
    profile.mkdir(parents=True, exist_ok=True)
    options.add_argument(f"--user-data-dir={profile}")
    service = Service(executable_path=shutil.which("chromedriver"), log_output=str(Path(workdir) / "chromedriver.log"))
    driver = webdriver.Chrome(service=service, options=options)
    driver.set_script_timeout(120)
    return driver


#: The open notebook's panel, as JavaScript: JupyterLab may leave ``currentWidget`` empty while the headless page
#: has no focus, so the main area's notebook is taken then.
PANEL = "(window.jupyterapp.shell.currentWidget || Array.from(window.jupyterapp.shell.widgets('main'))" \
        ".find((w) => w.sessionContext))"

#: Runs ``code`` in the kernel of the current notebook; resolves to its stdout and any error.
KERNEL_EXECUTE = r"""
const [code, done] = [arguments[0], arguments[arguments.length - 1]];
const panel = PANEL;
const kernel = panel.sessionContext.session.kernel;
const future = kernel.requestExecute({code: code, silent: false, store_history: false});
let out = '', err = null;
future.onIOPub = (msg) => {
  const t = msg.header.msg_type;
  if (t === 'stream') out += msg.content.text;
  if (t === 'error') err = msg.content.ename + ': ' + msg.content.evalue;
};
future.done.then(() => done({out: out, err: err}), (e) => done({out: out, err: String(e)}));
""".replace("PANEL", PANEL)

#: The state of the open notebook: is its kernel there, has it unsaved changes (``dirty``), how many code cells
#: ran, which errors they show.
NOTEBOOK_STATE = r"""
const app = window.jupyterapp;
if (!app || !app.shell) return null;
const panel = PANEL;
if (!panel || !panel.content || !panel.sessionContext) return null;
const session = panel.sessionContext.session;
const kernel = session ? session.kernel : null;
const cells = panel.content.widgets.filter((c) => c.model.type === 'code');
const errors = [];
for (const c of cells) {
  for (let i = 0; i < c.model.outputs.length; i++) {
    const o = c.model.outputs.get(i);
    if (o.type === 'error') errors.push(JSON.stringify(o.toJSON()).slice(0, 3000));
  }
}
return {kernel: kernel ? kernel.status : null, ready: panel.sessionContext.isReady,
        dirty: panel.context ? panel.context.model.dirty : null,
        cells: cells.length, executed: cells.filter((c) => c.model.executionCount !== null).length,
        errors: errors};
""".replace("PANEL", PANEL)


def notebook_state(driver):
    return driver.execute_script(NOTEBOOK_STATE)


def open_notebook(driver, lab, name, timeout=120):
    """Open ``name`` (under the server's root) and wait until its kernel is ready."""
    driver.get(lab.url(f"lab/tree/{name}"))

    def ready():
        s = notebook_state(driver)
        return s if s and s["ready"] and s["kernel"] in ("idle", "busy") else None

    return wait_for(ready, timeout, f"{name} to open with a ready kernel", interval=0.25)


def run_all_cells(driver, timeout=240):
    """Run every cell (JupyterLab's own *Run All Cells*) and wait until each code cell has run; errors raise."""
    driver.execute_script("window.jupyterapp.commands.execute('notebook:run-all-cells');")

    def finished():
        s = notebook_state(driver)
        if s["errors"]:
            raise AssertionError("a notebook cell failed:\n" + "\n".join(s["errors"]))
        return s if s["executed"] == s["cells"] else None

    return wait_for(finished, timeout, "every cell to run", interval=0.25)


def kernel_execute(driver, code) -> str:
    """Run ``code`` in the notebook's kernel (not in a cell) and return what it printed; an error raises."""
    result = driver.execute_async_script(KERNEL_EXECUTE, code)
    if result["err"]:
        raise AssertionError(f"kernel code failed: {result['err']}\n{code}")
    return result["out"]


def kernel_json(driver, expression):
    """The value of a JSON-serialisable ``expression`` evaluated in the notebook's kernel."""
    out = kernel_execute(driver, f"import json as _json; print(_json.dumps({expression}))")
    return json.loads(out.strip().splitlines()[-1])
