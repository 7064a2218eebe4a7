"""The Jupyter Server extension that turns Nagle's algorithm off on kernel websockets (tissuefem.surgery.nodelay):
the connection class it makes, its loading into a server's settings, and that installing the package enables it
(the server's own command line, as a subprocess)."""

import json
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from tissuefem.surgery.nodelay import _jupyter_server_extension_points, _load_jupyter_server_extension, without_nagle

ROOT = Path(__file__).resolve().parents[2]


class Connection:
    """A stand-in for Jupyter Server's kernel websocket connection: records what happened, in order."""

    def __init__(self, events):
        self.events = events
        self.websocket_handler = SimpleNamespace(set_nodelay=lambda on: events.append(("nodelay", on)))

    def connect(self):
        self.events.append(("connect",))
        return "future"


def test_the_connection_turns_nagle_off_before_it_connects():
    events = []
    connection = without_nagle(Connection)(events)
    assert isinstance(connection, Connection)
    assert connection.connect() == "future", "connect returns what the server's connection returns"
    assert events == [("nodelay", True), ("connect",)]
    assert type(connection).__name__ == "NoDelayConnection"


def test_loading_the_extension_wraps_the_servers_connection_class():
    logged = []
    app = SimpleNamespace(web_app=SimpleNamespace(settings={"kernel_websocket_connection_class": Connection}),
                          log=SimpleNamespace(info=logged.append))
    _load_jupyter_server_extension(app)
    cls = app.web_app.settings["kernel_websocket_connection_class"]
    assert issubclass(cls, Connection) and cls is not Connection
    assert logged and "Nagle" in logged[0]
    assert _jupyter_server_extension_points() == [{"module": "tissuefem.surgery.nodelay"}]


def test_it_subclasses_jupyter_servers_own_connection():
    channels = pytest.importorskip("jupyter_server.services.kernels.connection.channels")
    cls = without_nagle(channels.ZMQChannelsWebsocketConnection)
    assert issubclass(cls, channels.ZMQChannelsWebsocketConnection)


def test_the_package_ships_the_configuration_that_enables_it():
    shipped = ROOT / "jupyter-config" / "jupyter_server_config.d" / "tissuefem.json"
    enabled = {"ServerApp": {"jpserver_extensions": {"tissuefem.surgery.nodelay": True}}}
    assert json.loads(shipped.read_text()) == enabled
    assert ('"jupyter-config/jupyter_server_config.d/tissuefem.json" = '
            '"etc/jupyter/jupyter_server_config.d/tissuefem.json"') in (ROOT / "pyproject.toml").read_text()


@pytest.mark.slow
def test_the_installed_server_lists_it_enabled_and_valid():
    pytest.importorskip("jupyter_server")
    run = subprocess.run([sys.executable, "-m", "jupyter", "server", "extension", "list"], capture_output=True,
                         text=True, timeout=120)
    listed = re.sub(r"\x1b\[[0-9;]*m", "", run.stdout + run.stderr)  # without the colours
    lines = [" ".join(line.split()) for line in listed.splitlines()]
    assert "tissuefem.surgery.nodelay enabled" in lines, f"`pip install -e .` did not enable the extension:\n{listed}"
    assert "tissuefem.surgery.nodelay OK" in lines, f"the server cannot load the extension:\n{listed}"
