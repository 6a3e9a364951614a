"""A websocket policy server a lab can leave running on its network.

Wire-compatible with openpi's websocket policy protocol (``openpi_client.WebsocketClientPolicy`` works against
it unchanged): on connect the server sends its metadata as the first binary frame; each binary msgpack frame
from the client is an observation (``schema``) and gets one binary reply; a request that cannot be served gets
a text frame with a structured JSON error (openpi's client raises it). A token, when set, is checked on the
opening handshake (``Authorization: Api-Key <token>``, compared in constant time).

What openpi's server does not do and this one does: a loopback bind unless a token guards the port, a size limit
on frames (above it a structured error; above ``HARD_LIMIT_FACTOR`` x it websockets closes the connection
unread), an idle timeout per connection, a connection limit, ``GET /healthz``, and a policy state per connection
and episode. No traceback ever leaves the server.
"""

from __future__ import annotations

import asyncio
import copy
import hmac
import ipaddress
import json
import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response

from bimanualshift.core.policy import Policy
from bimanualshift.core.threads import policy_threads
from bimanualshift.deploy.codec import CodecError, pack, unpack
from bimanualshift.deploy.schema import (
    SCHEMA_VERSION,
    SchemaError,
    describe,
    error_frame,
    parse_observation,
    reply_message,
)

log = logging.getLogger("bimanualshift.serve")

HARD_LIMIT_FACTOR = 4  # frames above limit x this are refused by websockets before they are buffered whole
HEALTH_PATH = "/healthz"


@dataclass
class ServerConfig:
    host: str = "127.0.0.1"
    port: int = 8000  # 0: any free port (``PolicyServer.port`` tells which)
    token: str | None = None  # clients must send ``Authorization: Api-Key <token>``
    max_message_bytes: int = 32 * 2**20
    idle_timeout_s: float = 300.0  # a connection that sends nothing for this long is closed
    max_connections: int = 32
    inference_threads: int = 4  # decoding and encoding overlap across connections; the policy runs one at a time


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_bind(host: str, token: str | None) -> None:
    """Refuse to expose an unauthenticated policy beyond this machine."""
    if not is_loopback(host) and not token:
        raise ValueError(f"refusing to bind {host!r} without a token: anyone on the network could drive the robot. "
                         "Pass --token-file FILE (a secret the clients send as their API key), or bind 127.0.0.1")


def fork_policy(policy: Policy) -> Policy:
    """A copy of ``policy`` with its own episode state and shared (frozen) weights: one per connection.
    A policy with a ``fork()`` method decides itself; otherwise a shallow copy, reset (policies keep their
    per-episode state in attributes that ``reset`` reassigns)."""
    fork = getattr(policy, "fork", None)
    copied = fork() if callable(fork) else copy.copy(policy)
    copied.reset()
    return copied


@dataclass
class Session:
    """One connection's policy and the episode it is in."""

    policy: Policy
    episode_id: str | None = None
    requests: int = 0
    episodes: int = 0

    def start_if_new(self, episode_id: str, keyframe: int) -> None:
        if episode_id != self.episode_id or keyframe == 0:
            self.policy.reset()
            self.episode_id = episode_id
            self.episodes += 1


@dataclass
class PolicyServer:
    policy: Policy
    metadata: dict[str, Any]
    config: ServerConfig = field(default_factory=ServerConfig)
    # an observation the policy cannot read (a checkpoint that segments with the simulator's maps gets none)
    # (an accepted observation's checks may return a dict for the reply's diagnostics)
    check: Callable[[Any], dict[str, Any] | None] | None = None

    def __post_init__(self) -> None:
        check_bind(self.config.host, self.config.token)
        self._policy_lock = threading.Lock()
        self._pool = ThreadPoolExecutor(self.config.inference_threads, thread_name_prefix="policy")
        self._connections = 0
        self._stop: asyncio.Future | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self.port = self.config.port
        self.served = 0
        self.errors = 0

    # -- the opening handshake --------------------------------------------------------------------------------
    def _process_request(self, connection: ServerConnection, request: Request) -> Response | None:
        if request.path == HEALTH_PATH:
            body = json.dumps({"status": "ok", "schema_version": SCHEMA_VERSION, "connections": self._connections})
            return connection.respond(200, body + "\n")
        if self.config.token is not None:
            sent = request.headers.get("Authorization", "")
            if not hmac.compare_digest(sent.encode(), f"Api-Key {self.config.token}".encode()):
                log.warning("refused a connection from %s: missing or wrong API key", connection.remote_address)
                return connection.respond(401, "missing or wrong API key (send 'Authorization: Api-Key <token>')\n")
        if self._connections >= self.config.max_connections:
            return connection.respond(503, f"server busy: {self._connections} connections (limit "
                                           f"{self.config.max_connections})\n")
        return None

    # -- one request --------------------------------------------------------------------------------------------
    def _serve_frame(self, session: Session, frame: bytes) -> bytes | str:
        """A reply frame (bytes) or an error frame (str); runs on a pool thread."""
        t0 = time.perf_counter()
        limit = self.config.max_message_bytes
        if len(frame) > limit:
            return error_frame("too_large", "message", f"at most {limit} bytes", f"{len(frame)} bytes")
        try:
            parsed = parse_observation(unpack(frame))
            checked = self.check(parsed) if self.check is not None else None  # may describe what it accepted
        except CodecError as err:
            return error_frame("bad_frame", "message", "a msgpack frame of the observation schema", str(err))
        except SchemaError as err:
            return json.dumps({"error": err.as_dict(), "schema_version": SCHEMA_VERSION})
        t1 = time.perf_counter()
        obs = parsed.observation
        try:
            # one intra-op thread per op, as in every benchmark episode: the robot does what the benchmark measured
            with self._policy_lock, policy_threads():
                session.start_if_new(parsed.episode_id, obs.keyframe_index)
                action = np.asarray(session.policy.act(obs), np.float32)
                log_fn = getattr(session.policy, "keyframe_log", None)
                diagnostics = log_fn() if callable(log_fn) else {}
                chunk_fn = getattr(session.policy, "action_chunk", None)  # (arms, k, 9) where a policy plans ahead
                chunk = chunk_fn() if callable(chunk_fn) else None
                chunk = None if chunk is None else np.asarray(chunk, np.float32)
        except (ValueError, KeyError) as err:  # the policy's own refusal of this observation
            return error_frame("policy_error", "observation", "an observation this policy can act on",
                               f"{type(err).__name__}: {err}")
        except Exception as err:  # a bug: logged here with its traceback, never sent
            log.exception("policy failed on episode %s keyframe %s", parsed.episode_id, obs.keyframe_index)
            return error_frame("internal", "policy", "an action", f"{type(err).__name__} (see the server's log)")
        t2 = time.perf_counter()
        if action.shape != (len(obs.scene.arm_names), 9) or not np.isfinite(action).all():
            log.error("policy returned %s", describe(action))
            return error_frame("internal", "policy", "finite (arms, 9) action rows", describe(action))
        timing = {"decode_ms": 1e3 * (t1 - t0), "infer_ms": 1e3 * (t2 - t1)}
        if isinstance(checked, dict):
            diagnostics = {**checked, **diagnostics}
        reply = reply_message(parsed.episode_id, obs.keyframe_index, obs.scene.arm_names, action, timing,
                              _plain(diagnostics))
        if chunk is not None:
            reply["chunk"] = chunk
        reply["timing"]["server_ms"] = 1e3 * (time.perf_counter() - t0)
        session.requests += 1
        return pack(reply)

    async def _handler(self, ws: ServerConnection) -> None:
        self._connections += 1
        session = Session(fork_policy(self.policy))
        loop = asyncio.get_running_loop()
        try:
            await ws.send(pack(self.metadata))
            while True:
                try:
                    frame = await asyncio.wait_for(ws.recv(), self.config.idle_timeout_s)
                except TimeoutError:
                    await ws.close(1000, f"idle for {self.config.idle_timeout_s:g} s")
                    return
                if isinstance(frame, str):
                    reply: bytes | str = error_frame("bad_frame", "message", "a binary msgpack frame",
                                                     "a text frame")
                else:
                    reply = await loop.run_in_executor(self._pool, self._serve_frame, session, frame)
                if isinstance(reply, str):
                    self.errors += 1
                else:
                    self.served += 1
                await ws.send(reply)
        except ConnectionClosed:
            pass
        finally:
            self._connections -= 1

    # -- running --------------------------------------------------------------------------------------------------
    async def run(self, ready: threading.Event | None = None) -> None:
        self._loop = asyncio.get_running_loop()
        self._stop = self._loop.create_future()
        async with serve(self._handler, self.config.host, self.config.port, process_request=self._process_request,
                         max_size=HARD_LIMIT_FACTOR * self.config.max_message_bytes, compression=None,
                         ping_interval=20, ping_timeout=20, close_timeout=5, open_timeout=10) as server:
            self.port = server.sockets[0].getsockname()[1]
            log.info("serving %s on ws://%s:%d (token: %s)", self.metadata.get("checkpoint"), self.config.host,
                     self.port, "required" if self.config.token else "none")
            if ready is not None:
                ready.set()
            await self._stop

    def serve_forever(self) -> None:
        try:
            asyncio.run(self.run())
        except KeyboardInterrupt:
            pass
        finally:
            self._pool.shutdown(wait=False, cancel_futures=True)

    def start_background(self) -> PolicyServer:
        """Serve from a daemon thread (tests, benchmarks); ``stop()`` ends it."""
        ready = threading.Event()
        self._thread = threading.Thread(target=lambda: asyncio.run(self.run(ready)), daemon=True)
        self._thread.start()
        if not ready.wait(30):
            raise RuntimeError("the policy server did not start within 30 s")
        return self

    def stop(self) -> None:
        if self._loop is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(lambda: self._stop.done() or self._stop.set_result(None))
        thread = getattr(self, "_thread", None)
        if thread is not None:
            thread.join(10)
        self._pool.shutdown(wait=False, cancel_futures=True)


def _plain(value: Any) -> Any:
    """JSON-like values only (numpy scalars and arrays become numbers and lists) in the diagnostics."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value

