"""The simulated wind without processes (docs/plant-link.md, "Wind"): the Dryden turbulence's statistics and its
seed, the plant's wind parameters on the plant link, the autopilot's view of them (read from the plant, set on it),
and the wind as users give it (Wind, `vtol up`, campaigns)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest

from aircraft.airframe import load_airframe
from autopilot.commander.plant_parameter_sync import RESEND_USEC, PlantParameterSync
from autopilot.storage.parameters import ParameterStore
from ground_tools.campaign.spec import CampaignError, parse_campaign, plant_wind
from sim_bridge.plant import Plant, Spawn
from sim_bridge.plant_parameters import PlantParameterService
from sim_bridge.wind import FEET, WindModel, dryden_scales, gust_step
from tiltrotor_sitl import Wind
from tiltrotor_sitl._commands import SimCommand
from tiltrotor_sitl._commands import plant_wind as sim_wind
from transport.mavlink import Link
from transport.mavlink import mavlink as M
from transport.plant_parameters import BY_NAME, encode
from transport.wind import speed_and_direction

DT = 0.0025


def test_the_wind_as_users_give_it():
    north, east = Wind(10.0, 270.0).north_east  # from the west: blows east
    assert north == pytest.approx(0.0, abs=1e-12) and east == pytest.approx(10.0)
    assert speed_and_direction(0.0, 10.0) == pytest.approx((10.0, 270.0))
    assert speed_and_direction(-3.0, 0.0) == pytest.approx((3.0, 0.0))  # blowing south: from the north
    with pytest.raises(ValueError, match="SIM_WIND_SPD: 70 outside 0..60"):
        Wind(70.0).check()
    with pytest.raises(ValueError, match="SIM_WIND_SEED: 1.5 is not an integer"):
        Wind(seed=1.5).check()  # type: ignore[arg-type]
    argv = SimCommand(**sim_wind(Wind(5.0, 90.0, 1.5, 7))).argv()
    assert "--wind-turbulence" in argv and "1.5" in argv and "--wind-seed" in argv and "7" in argv
    wind = next(arg for arg in argv if arg.startswith("--wind="))
    assert [float(v) for v in wind.removeprefix("--wind=").split(",")] == pytest.approx([0.0, -5.0, 0.0], abs=1e-12)


def test_dryden_scales_are_the_handbooks_at_low_altitude():
    lengths, sigmas = dryden_scales(20.0, 1.0)  # 65.6 ft
    h = 20.0 / FEET
    assert lengths[2] == pytest.approx(20.0)
    assert lengths[0] == pytest.approx(h / (0.177 + 0.000823 * h) ** 1.2 * FEET) and lengths[0] == lengths[1]
    assert sigmas[0] == pytest.approx(1.0 / (0.177 + 0.000823 * h) ** 0.4) and sigmas[2] == 1.0
    assert dryden_scales(0.0, 1.0)[0][2] == pytest.approx(10 * FEET)  # the model's floor, 10 ft


def test_the_gusts_have_the_models_deviation_and_correlation_time():
    rng = np.random.default_rng(5)
    lengths, sigmas, speed = np.array([30.0, 30.0, 10.0]), np.array([2.0, 2.0, 1.0]), 10.0
    gusts, samples = np.zeros(3), []
    for _ in range(400_000):
        gusts = gust_step(gusts, rng.standard_normal(3), speed, DT, lengths, sigmas)
        samples.append(gusts)
    series = np.array(samples)
    assert series.std(axis=0) == pytest.approx(sigmas, rel=0.08)
    lag = int(round(10.0 / speed / DT))  # one correlation time of w (L / V = 1 s): e^-1
    correlation = np.corrcoef(series[:-lag, 2], series[lag:, 2])[0, 1]
    assert correlation == pytest.approx(math.exp(-1.0), abs=0.06)


def wind_series(model: WindModel, steps: int = 2000) -> np.ndarray:
    return np.array([model.step(20.0, np.zeros(3), DT).copy() for _ in range(steps)])


def test_the_same_seed_gives_the_same_gusts_bit_for_bit_and_another_seed_others():
    mean = (*Wind(5.0, 270.0).north_east, 0.0)
    first, again = wind_series(WindModel(mean, 1.5, 3)), wind_series(WindModel(mean, 1.5, 3))
    other = wind_series(WindModel(mean, 1.5, 4))
    assert np.array_equal(first, again) and not np.array_equal(first, other)
    calm = wind_series(WindModel(mean, 0.0, 3))
    assert np.all(calm == np.array(mean))
    reseeded = WindModel(mean, 1.5, 4)
    reseeded.set(Wind(5.0, 270.0, 1.5, 3))
    assert np.array_equal(wind_series(reseeded), first)


def test_the_plant_flies_in_its_wind():
    """Hovering with the rotors held, a 20 m/s wind from the west pushes the plant east (a wind near 10 m/s hardly
    does: the paper's aerodynamics fade in with e(V), zero at 10 m/s)."""
    airframe = load_airframe()
    plant = Plant(airframe, Spawn(altitude=50.0), wind=WindModel((0.0, 20.0, 0.0)))
    for _ in range(2000):
        plant.step()
    assert plant.state[4] > 5.0 and plant.airspeed[0] < 15.0


def param_set(name: str, value: float, kind: int | None = None, target: tuple[int, int] = (1, 200)):
    parameter = BY_NAME[name]
    return M.MAVLink_param_set_message(*target, name.encode(), encode(parameter, value),
                                       kind if kind is not None else (6 if parameter.kind == "INT32" else 9))  # fmt: skip


def plant_service() -> PlantParameterService:
    return PlantParameterService.for_command_line((3.0, 4.0, 0.0), 0.0, 0, Link(1, 200))


def test_the_plant_answers_its_parameters_and_applies_a_set():
    service = plant_service()
    assert service.values() == pytest.approx({"SIM_WIND_SPD": 5.0, "SIM_WIND_DIR": math.degrees(math.atan2(-4, -3))
                                              % 360, "SIM_WIND_TURB": 0.0, "SIM_WIND_SEED": 0.0})  # fmt: skip
    listed = service.answer(M.MAVLink_param_request_list_message(1, 200))
    assert [v.param_id for v in listed.values] == list(BY_NAME) and listed.values[0].param_count == 4
    answer = service.answer(param_set("SIM_WIND_DIR", 270.0))
    assert answer.values[0].param_value == 270.0 and not answer.said[0][1]
    assert service.wind_model.mean_ned == pytest.approx([0.0, 5.0, 0.0], abs=1e-12)
    answer = service.answer(param_set("SIM_WIND_SEED", 42))
    assert service.wind_model.seed == 42 and answer.values[0].param_value == encode(BY_NAME["SIM_WIND_SEED"], 42)


@pytest.mark.parametrize("message, why", [
    (param_set("SIM_WIND_SPD", 99.0), "SIM_WIND_SPD: 99 outside 0..60"),
    (param_set("SIM_WIND_SPD", math.nan), "not a finite number"),
    (param_set("SIM_WIND_TURB", 1.0, kind=6), "type 6, need 9"),
])  # fmt: skip
def test_a_refused_set_answers_the_unchanged_value_and_says_why(message, why):
    service = plant_service()
    answer = service.answer(message)
    assert answer.values[0].param_value == encode(BY_NAME[message.param_id], service.values()[message.param_id])
    assert why in answer.said[0][0] and answer.said[0][1] and service.wind_model.mean_ned[1] == 4.0


def test_a_request_for_others_or_an_unknown_name_changes_nothing():
    service = plant_service()
    assert service.answer(param_set("SIM_WIND_SPD", 9.0, target=(2, 200))).values == []
    unknown = M.MAVLink_param_set_message(1, 200, b"SIM_WIND_X", 1.0, 9)
    assert service.answer(unknown).values == [] and "unknown" in service.answer(unknown).said[0][0]
    assert service.values()["SIM_WIND_SPD"] == 5.0


@dataclass
class FakePlantLink:
    """The plant end as PlantParameterSync sees it: what was asked of it."""

    shaken: bool = True
    requests: int = 0
    sets: list = field(default_factory=list)

    def request_plant_parameters(self) -> bool:
        self.requests += self.shaken
        return self.shaken

    def set_plant_parameter(self, name: str, param_value: float, param_type: int) -> bool:
        self.sets.append((name, param_value, param_type))
        return True


def value(name: str, v: float):
    parameter = BY_NAME[name]
    return M.MAVLink_param_value_message(name.encode(), encode(parameter, v), 9, 4, 0)


def test_the_autopilot_shows_the_plants_values_and_sets_only_what_changed():
    params, link = ParameterStore(None), FakePlantLink()
    sync = PlantParameterSync(params, link)
    params.set("SIM_WIND_SPD", 3.0)  # before the plant has answered: not sent (the plant's own value wins)
    sync.step(0)
    sync.step(RESEND_USEC - 1)
    assert link.requests == 1 and link.sets == []
    sync.step(RESEND_USEC)  # no answer: asked again
    assert link.requests == 2
    for name, v in (("SIM_WIND_SPD", 5.0), ("SIM_WIND_DIR", 90.0), ("SIM_WIND_TURB", 0.0), ("SIM_WIND_SEED", 0)):
        assert sync.answered(value(name, v)) is None
    assert params["SIM_WIND_SPD"] == 5.0 and params["SIM_WIND_DIR"] == 90.0
    sync.step(RESEND_USEC + 10)
    assert link.requests == 2 and link.sets == []
    params.set("SIM_WIND_TURB", 1.5)  # a ground station's set
    sync.step(RESEND_USEC + 20)
    sync.step(RESEND_USEC + 30)  # sent once, not again while its answer may come
    assert link.sets == [("SIM_WIND_TURB", 1.5, 9)]
    sync.answered(value("SIM_WIND_TURB", 1.5))
    sync.step(2 * RESEND_USEC + 40)
    assert len(link.sets) == 1 and params["SIM_WIND_TURB"] == 1.5
    assert "not one of" in sync.answered(M.MAVLink_param_value_message(b"OTHER", 1.0, 9, 4, 0))


def test_the_plants_parameters_stay_out_of_the_parameter_file(tmp_path):
    path = tmp_path / "params.json"
    params = ParameterStore(path)
    params.set("SIM_WIND_SPD", 7.0)
    params.set("MIS_TAKEOFF_ALT", 5.0)
    params.flush()
    assert "SIM_WIND" not in path.read_text()
    path.write_text('{"format": "tiltrotor-sitl parameters", "version": 1, "parameters": {"SIM_WIND_SPD": 7}}')
    reloaded = ParameterStore(path)
    reloaded.load()
    assert reloaded["SIM_WIND_SPD"] == 0.0 and "the plant keeps it" in reloaded.warnings[0]


def test_a_campaigns_wind_goes_to_the_plant(tmp_path):
    spec = {"scenario": "accel", "fixed": {"SIM_WIND_SPD": 6.0, "SIM_WIND_DIR": 90.0, "wind_d_mps": 0.5},
            "axes": {"SIM_WIND_SEED": [1, 2]}}  # fmt: skip
    parse_campaign(spec, "gusts", tmp_path)
    wind, turbulence, seed = plant_wind({"SIM_WIND_SPD": 6.0, "SIM_WIND_DIR": 90.0, "wind_d_mps": 0.5,
                                         "SIM_WIND_TURB": 1.5, "SIM_WIND_SEED": 2})  # fmt: skip
    assert wind == pytest.approx((0.0, -6.0, 0.5), abs=1e-12) and (turbulence, seed) == (1.5, 2)
    with pytest.raises(CampaignError, match="not both"):
        parse_campaign({"scenario": "accel", "fixed": {"SIM_WIND_SPD": 6.0, "wind_e_mps": 1.0}}, "x", tmp_path)
    with pytest.raises(CampaignError, match="SIM_WIND_TURB: 20 outside 0..10"):
        parse_campaign({"scenario": "accel", "axes": {"SIM_WIND_TURB": [1, 20]}}, "x", tmp_path)
