"""The policy server: openpi's real client against it, authentication, structured errors that leave the
connection usable, and a policy state per connection."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from conftest import TOKEN, CountingPolicy, valid_message
from openpi_client.websocket_client_policy import WebsocketClientPolicy
from websockets.sync.client import connect

from bimanualshift.cli.deploy import read_token
from bimanualshift.deploy.client import PolicyClient, ServerError, ServerUnavailable
from bimanualshift.deploy.malformed import CHECKPOINT_CLASSES, CLASSES, corpus
from bimanualshift.deploy.served_policy import ServedPolicy
from bimanualshift.deploy.server import PolicyServer, ServerConfig, check_bind

# what any server refuses from the message alone; the checkpoint's classes need its ``ServedPolicy.check``
MESSAGE_CLASSES = tuple(c for c in CLASSES if c not in CHECKPOINT_CLASSES and c != "token_file_mode")


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


@pytest.mark.parametrize("kind", MESSAGE_CLASSES)
def test_each_malformed_class_gets_a_structured_error_and_the_connection_stays_usable(
        server: PolicyServer, kind: str) -> None:
    cases = list(corpus(valid_message(), 4, 256 * 1024, TOKEN, seed=1, classes=(kind,)))
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


@pytest.fixture
def checked_server() -> Iterator[PolicyServer]:
    """A server that knows its checkpoint: two arms in order, keyframes up to 49, views that must see the table."""
    served = ServedPolicy(CountingPolicy(), {"checkpoint": "counting", "cameras": {"trained_with": ["front"]}},
                          needs_maps=False)
    srv = PolicyServer(served.policy, served.metadata, ServerConfig(port=0, token=TOKEN), check=served.check)
    srv.start_background()
    yield srv
    srv.stop()


@pytest.mark.parametrize("kind", CHECKPOINT_CLASSES)
def test_what_the_checkpoint_cannot_act_on_gets_a_structured_error_naming_the_field(
        checked_server: PolicyServer, kind: str) -> None:
    cases = list(corpus(valid_message(), 12, 256 * 1024, TOKEN, seed=2, max_keyframe=49, classes=(kind,)))
    client = PolicyClient(f"ws://127.0.0.1:{checked_server.port}", TOKEN)
    fields = {"keyframe_bound": "keyframe", "blind_views": "cameras", "foreign_arms": "arms"}[kind]
    for i, case in enumerate(cases):
        client._ws.send(case.frame)
        reply = client._ws.recv(timeout=10)
        assert isinstance(reply, str), f"{case.description}: answered with an action"
        error = json.loads(reply)["error"]
        assert error["field"].startswith(fields) and error["expected"] and "Traceback" not in reply, case.description
        assert client.infer(valid_message(keyframe=i + 1))["action"].shape == (2, 9)
    client.close()


def test_the_last_keyframe_of_the_bound_and_cameras_of_any_name_are_served(checked_server: PolicyServer) -> None:
    client = PolicyClient(f"ws://127.0.0.1:{checked_server.port}", TOKEN)
    assert client.infer(valid_message(keyframe=49))["keyframe"] == 49
    with pytest.raises(ServerError, match="keyframe") as err:
        client.infer(valid_message(keyframe=2**63 - 1))
    assert "0 to 49" in err.value.error["expected"]
    renamed = valid_message(keyframe=1)
    renamed["cameras"] = {"realsense_front": renamed["cameras"]["front"]}  # one calibrated view, another name
    views = client.infer(renamed)["diagnostics"]["views"]
    assert views["cameras"] == ["realsense_front"] and views["untrained_names"] == ["realsense_front"]
    assert views["coverage"] >= 0.5
    client.close()


@pytest.mark.parametrize("mode", [0o644, 0o640, 0o604, 0o660, 0o606, 0o777])
def test_a_token_file_other_users_can_read_or_change_is_refused(tmp_path: Path, mode: int) -> None:
    path = tmp_path / "token"
    path.write_text(TOKEN)
    path.chmod(mode)
    with pytest.raises(PermissionError, match=f"permissions {mode:04o}.*chmod 600"):
        read_token(str(path))
    path.chmod(0o600)
    assert read_token(str(path)) == TOKEN
