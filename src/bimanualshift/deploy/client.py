"""The robot side of the policy server: send an observation, get each arm's next keyframe."""

from __future__ import annotations

import json
import time
from typing import Any

from websockets.exceptions import ConnectionClosed, InvalidStatus, WebSocketException
from websockets.sync.client import ClientConnection, connect

from bimanualshift.deploy.codec import CodecError, pack, unpack


class ServerError(RuntimeError):
    """The server refused a request; ``error`` is its structured reply (code, field, expected, got, message)."""

    def __init__(self, error: dict[str, Any]) -> None:
        super().__init__(error.get("message", str(error)))
        self.error = error


class ServerUnavailable(ConnectionError):
    """The server cannot be reached, or went away mid-request."""


class PolicyClient:
    """A connection to ``bimanualshift serve``; ``infer`` sends one observation message and returns the reply.
    A lost connection raises ``ServerUnavailable``; ``reconnect`` (tried ``retries`` times with a growing pause)
    opens a new one."""

    def __init__(self, url: str, token: str | None = None, timeout_s: float = 60.0, retries: int = 3,
                 backoff_s: float = 0.5) -> None:
        self.url = url if url.startswith(("ws://", "wss://")) else f"ws://{url}"
        self.token, self.timeout_s, self.retries, self.backoff_s = token, timeout_s, retries, backoff_s
        self._ws: ClientConnection | None = None
        self.metadata: dict[str, Any] = {}
        self.reconnect()

    def _open(self) -> None:
        headers = {"Authorization": f"Api-Key {self.token}"} if self.token else None
        try:
            self._ws = connect(self.url, additional_headers=headers, compression=None, max_size=None,
                               open_timeout=self.timeout_s, legacy=True)  # a plain connection, closed by close()
            self.metadata = unpack(self._ws.recv(timeout=self.timeout_s))
        except InvalidStatus as err:
            status = err.response.status_code
            body = err.response.body.decode(errors="replace").strip() if err.response.body else ""
            raise ServerUnavailable(f"{self.url} refused the connection: HTTP {status} {body}") from None
        except (OSError, TimeoutError, WebSocketException, CodecError) as err:
            raise ServerUnavailable(f"cannot reach the policy server at {self.url}: {err}; is `bimanualshift serve` "
                                    "running there (check --server)?") from None

    def reconnect(self) -> None:
        self.close()
        for attempt in range(self.retries + 1):
            try:
                self._open()
                return
            except ServerUnavailable as err:
                if "refused the connection: HTTP 401" in str(err) or attempt == self.retries:
                    raise
                time.sleep(self.backoff_s * 2**attempt)

    def infer(self, message: dict[str, Any]) -> dict[str, Any]:
        if self._ws is None:
            raise ServerUnavailable("not connected: call reconnect()")
        try:
            self._ws.send(pack(message))
            reply = self._ws.recv(timeout=self.timeout_s)
        except (ConnectionClosed, OSError, TimeoutError) as err:
            self._ws = None
            raise ServerUnavailable(f"the policy server at {self.url} went away: {err}") from None
        if isinstance(reply, str):
            try:
                error = json.loads(reply)["error"]
            except (ValueError, KeyError, TypeError):
                error = {"code": "unknown", "message": reply[:500]}
            raise ServerError(error)
        return unpack(reply)

    def close(self) -> None:
        if self._ws is not None:
            try:
                self._ws.close()
            except Exception:  # closing a dead socket: nothing to report
                pass
            self._ws = None
