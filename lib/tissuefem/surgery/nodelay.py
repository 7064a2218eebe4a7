"""A Jupyter Server extension: the kernels' websockets send each message at once (no Nagle delay).

The live view's frames are small messages sent 30 times a second from the kernel, through the Jupyter server's
websocket, to the page. Jupyter Server leaves Nagle's algorithm on for that socket (Tornado's ``set_nodelay``),
so a message waits until the page's TCP stack acknowledges the one before it, and the page may hold that
acknowledgement back (delayed ACK): the browser benchmark measured about 11 ms from kernel to page with it and
3 ms without it. Installing tissuefem enables this extension in the environment's Jupyter configuration
(``jupyter_server_config.d/tissuefem.json``); ``jupyter server extension disable tissuefem.surgery.nodelay`` turns it
off. It only sets ``TCP_NODELAY`` on kernel websockets: what is sent does not change.
"""

from __future__ import annotations

__all__ = ["without_nagle"]


def without_nagle(connection_class):
    """A subclass of a kernel websocket connection class whose ``connect`` first turns Nagle's algorithm off."""

    class NoDelay(connection_class):
        def connect(self):
            self.websocket_handler.set_nodelay(True)
            return super().connect()

    NoDelay.__name__ = NoDelay.__qualname__ = f"NoDelay{connection_class.__name__}"
    return NoDelay


def _jupyter_server_extension_points():
    return [{"module": "tissuefem.surgery.nodelay"}]


def _load_jupyter_server_extension(serverapp) -> None:
    settings = serverapp.web_app.settings
    settings["kernel_websocket_connection_class"] = without_nagle(settings["kernel_websocket_connection_class"])
    serverapp.log.info("tissuefem: kernel websockets send without Nagle's delay")
