"""The README's scenario example is real: it validates against the schema."""

import re
from pathlib import Path

import yaml

from uhrisim.scenario.load import validate_data

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_scenario_example_validates():
    blocks = re.findall(r"```yaml\n(.*?)```", README.read_text(), flags=re.S)
    assert blocks, "README has no yaml example"
    scenario = validate_data(yaml.safe_load(blocks[0]), "README.md")
    assert [a.name for a in scenario.agents] == ["diver", "videoray"]
    assert scenario.agents[1].contacts.position_noise_std == 0.2
