import pytest

from avionics.config import Config, ConfigError, load_config


def test_default_toml_spells_out_the_builtin_defaults():
    assert load_config("config/default.toml") == Config()


def test_overrides_parse_as_toml_and_bare_strings():
    cfg = load_config(overrides=["advisory.ta_min_duration_s=10", "vehicle.id=uav7",
                                 'zenoh.connect=["tcp/127.0.0.1:9000"]', "vehicle.own_icao=0xABCDEF"])
    assert cfg.advisory.ta_min_duration_s == 10.0
    assert cfg.vehicle.id == "uav7"
    assert cfg.zenoh.connect == ("tcp/127.0.0.1:9000",)
    assert cfg.vehicle.own_icao == 0xABCDEF


@pytest.mark.parametrize("override, message", [
    ("advisory.nope=1", "unknown key"),
    ("advisory.assessment_hz=0", "must be > 0"),
    ("advisory.assessment_hz=true", "finite number"),
    ("zenoh.mode=router2", "peer, client or router"),
    ("vehicle.own_icao=0x1000000", "24-bit"),
    ("tracking.delete_after_s=1", "delete_after_s"),
    ("novalue", "section.key=value"),
])
def test_bad_configuration_is_a_clear_error(override, message):
    with pytest.raises(ConfigError, match=message):
        load_config(overrides=[override])


def test_bad_file_names_the_file(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("[advisory\n")
    with pytest.raises(ConfigError, match="bad.toml"):
        load_config(path)
