"""The policy server: openpi's real client against it, authentication, structured errors that leave the
connection usable, and a policy state per connection."""

from __future__ import annotations

import json
import threading

import numpy as np
import pytest
from conftest import TOKEN, valid_message
from openpi_client.websocket_client_policy import WebsocketClientPolicy
from websockets.sync.client import connect

from bimanualshift.deploy.client import PolicyClient, ServerError, ServerUnavailable
from bimanualshift.deploy.malformed import CLASSES, corpus
from bimanualshift.deploy.server import PolicyServer, ServerConfig, check_bind


def test_openpi_client_gets_metadata_actions_and_errors(server: PolicyServer) -> None:
    client = WebsocketClientPolicy("127.0.0.1", server.port, api_key=TOKEN)
    assert client.get_server_metadata()["checkpoint"] == "counting"
    reply = client.infer(valid_message())
    assert reply["schema_version"] == 1 and reply["action"].shape == (2, 9)
    assert reply["actions"]["left"]["pose"][2] == pytest.approx(1.01)
    assert reply["diagnostics"] == {"count": 1, "retrieval_similarity": 0.5}
    assert reply["chunk"].shape == (2, 2, 9)
    broken = valid_message()
    broken["cameras"]["front"]["depth"] = broken["cameras"]["front"]["depth"].astype(np.int32)
    with pytest.raises(RuntimeError, match="Error in inference server") as err:
        client.infer(broken)
    error = json.loads(str(err.value).split("\n", 1)[1])["error"]
    assert error["field"] == "cameras.front.depth" and "float" in error["expected"] and "int32" in error["got"]
    assert client.infer(valid_message(keyframe=1))["actions"]["left"]["pose"][2] == pytest.approx(1.02)


@pytest.mark.parametrize("key", [None, "wrong-token-of-some-length", TOKEN[:-1]])
def test_a_missing_or_wrong_key_is_refused(server: PolicyServer, key: str | None) -> None:
    with pytest.raises(Exception, match="401"):
        WebsocketClientPolicy("127.0.0.1", server.port, api_key=key)
    with pytest.raises(ServerUnavailable, match="HTTP 401"):
        PolicyClient(f"ws://127.0.0.1:{server.port}", key, retries=0)


def test_non_loopback_bind_needs_a_token() -> None:
    with pytest.raises(ValueError, match="without a token"):
        check_bind("0.0.0.0", None)
    with pytest.raises(ValueError, match="without a token"):
        PolicyServer(None, {}, ServerConfig(host="192.168.1.5"))  # type: ignore[arg-type]
    check_bind("0.0.0.0", "secret-token")
    check_bind("127.0.0.1", None)
    check_bind("::1", None)


def test_health_check(server: PolicyServer) -> None:
    import urllib.request

    with urllib.request.urlopen(f"http://127.0.0.1:{server.port}/healthz", timeout=5) as response:
        assert response.status == 200 and json.loads(response.read())["status"] == "ok"


@pytest.mark.parametrize("kind", CLASSES)
def test_each_malformed_class_gets_a_structured_error_and_the_connection_stays_usable(
        server: PolicyServer, kind: str) -> None:
    cases = [c for c in corpus(valid_message(), 4, 256 * 1024, TOKEN, seed=1) if c.kind == kind]
    client = PolicyClient(f"ws://127.0.0.1:{server.port}", TOKEN)
    for i, case in enumerate(cases):
        if case.kind == "wrong_token":
            with pytest.raises(ServerUnavailable, match="401"):
                PolicyClient(f"ws://127.0.0.1:{server.port}", case.token, retries=0)
        else:
            client._ws.send(case.frame)  # the raw frame, as a hostile peer would send it
            reply = client._ws.recv(timeout=10)
            assert isinstance(reply, str), f"{case.description}: expected an error frame"
            error = json.loads(reply)["error"]
            assert error["code"] and error["field"] and error["message"], case.description
            assert "Traceback" not in reply
        served = client.infer(valid_message(keyframe=i))
        assert served["action"].shape == (2, 9)
    client.close()


def test_oversized_beyond_the_hard_limit_closes_only_that_connection(server: PolicyServer) -> None:
    with connect(f"ws://127.0.0.1:{server.port}", additional_headers={"Authorization": f"Api-Key {TOKEN}"},
                 max_size=None) as ws:
        ws.recv()
        ws.send(b"\0" * (5 * 256 * 1024))
        with pytest.raises(Exception, match="1009|too big"):
            ws.recv(timeout=10)
    assert PolicyClient(f"ws://127.0.0.1:{server.port}", TOKEN).infer(valid_message())["keyframe"] == 0


def test_each_connection_and_episode_has_its_own_policy_state(server: PolicyServer) -> None:
    a = PolicyClient(f"ws://127.0.0.1:{server.port}", TOKEN)
    b = PolicyClient(f"ws://127.0.0.1:{server.port}", TOKEN)
    assert [a.infer(valid_message("A", k))["diagnostics"]["count"] for k in range(3)] == [1, 2, 3]
    assert b.infer(valid_message("B", 0))["diagnostics"]["count"] == 1  # not 4: b has its own state
    assert a.infer(valid_message("A", 3))["diagnostics"]["count"] == 4
    assert a.infer(valid_message("A2", 5))["diagnostics"]["count"] == 1  # a new episode id resets
    assert a.infer(valid_message("A2", 0))["diagnostics"]["count"] == 1  # keyframe 0 resets too
    counts: list[int] = []

    def episode(name: str) -> None:
        c = PolicyClient(f"ws://127.0.0.1:{server.port}", TOKEN)
        counts.extend(c.infer(valid_message(name, k))["diagnostics"]["count"] for k in range(4))
        c.close()

    threads = [threading.Thread(target=episode, args=(f"T{i}",)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(counts) == sorted([1, 2, 3, 4] * 4)


def test_a_failing_policy_answers_without_a_traceback() -> None:
    class Broken:
        name = "broken"

        def reset(self) -> None: ...

        def act(self, obs: object) -> np.ndarray:
            raise RuntimeError("secret internals /home/lab/model.py line 12")

    srv = PolicyServer(Broken(), {}, ServerConfig(port=0)).start_background()  # type: ignore[arg-type]
    try:
        client = PolicyClient(f"ws://127.0.0.1:{srv.port}")
        with pytest.raises(ServerError) as err:
            client.infer(valid_message())
        assert err.value.error["code"] == "internal" and "secret internals" not in str(err.value.error)
        with pytest.raises(ServerError):  # still answering
            client.infer(valid_message())
    finally:
        srv.stop()
