from pathlib import Path

import pytest

from bimanualshift.data.episode import read_episode
from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.deploy.codec import pack, unpack
from bimanualshift.deploy.schema import SchemaError, observation_message, parse_observation


def test_the_scene_crosses_the_wire_with_its_colours(bimanual_episode_path: Path) -> None:
    """A simulated robot's observation arrives with the goal prompts and the painted colours they match."""
    obs = KeyframeObservation.from_episode(read_episode(bimanual_episode_path), 0)
    assert obs.scene.instance_colours
    parsed = parse_observation(unpack(pack(observation_message(obs, "e0"))))
    assert parsed.observation.scene.instance_colours == obs.scene.instance_colours
    assert parsed.observation.scene.goal_nouns == obs.scene.goal_nouns


def test_malformed_instance_colours_name_the_field(bimanual_episode_path: Path) -> None:
    obs = KeyframeObservation.from_episode(read_episode(bimanual_episode_path), 0)
    msg = observation_message(obs, "e0")
    msg["instance_colours"] = {"button_0": "navy"}
    with pytest.raises(SchemaError) as err:
        parse_observation(msg)
    assert err.value.field == "instance_colours.button_0"
