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
from ground_tools.campaign.spec import CampaignError, parse_campaign, plant_wind, scenario_parameters
from ground_tools.cli import parser
from ground_tools.up import commands as up_commands
from sim_bridge.plant import Plant, Spawn
from sim_bridge.plant_parameters import PlantParameterService
from sim_bridge.wind import DRYDEN_HEIGHT_M, FEET, WindModel, dryden_scales
from tiltrotor_sitl import Wind
from tiltrotor_sitl._commands import SimCommand
from tiltrotor_sitl._commands import plant_wind as sim_wind
from transport.mavlink import Link
from transport.mavlink import mavlink as M
from transport.plant_parameters import BY_NAME, encode
from transport.wind import from_velocity

DT = 0.0025


def test_the_wind_as_users_give_it():
    assert Wind(from_north=10.0).velocity_ne == (-10.0, -0.0)  # from the north: the air moves south
    assert from_velocity(0.0, 10.0) == Wind(from_east=-10.0)  # moving east: from the west
    with pytest.raises(ValueError, match="SIH_WIND_N: 70 outside -40..40"):
        Wind(70.0).check()
    with pytest.raises(ValueError, match="SIM_WIND_SEED: 1.5 is not an integer"):
        Wind(seed=1.5).check()  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="SIM_WIND_TURB must be a number"):
        Wind(turbulence="strong").check()  # type: ignore[arg-type]
    argv = SimCommand(**sim_wind(Wind(0.0, 5.0, 1.5, 7))).argv()
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


def test_the_turbulence_has_the_models_deviations_and_correlation_lengths():
    """Over 20 000 s of an 8 m/s wind from the west (the exact discretisation holds for any step, so 0.25 s steps
    keep it quick): each gust's standard deviation is the model's, and its autocorrelation one scale length
    downwind (a lag of L / V) is e^-1, the first-order filter's."""
    speed, dt, turbulence = 8.0, 0.25, 1.5
    model = WindModel((speed, 0.0, 0.0), turbulence, seed=11)
    series = np.array([model.step(dt).copy() for _ in range(80_000)]) - model.mean_ned
    lengths, sigmas = dryden_scales(DRYDEN_HEIGHT_M, turbulence)
    assert series.std(axis=0) == pytest.approx(sigmas, rel=0.1)
    for axis in range(3):
        lag = int(round(lengths[axis] / speed / dt))
        correlation = np.corrcoef(series[:-lag, axis], series[lag:, axis])[0, 1]
        assert correlation == pytest.approx(math.exp(-1.0), abs=0.08), axis
    assert sigmas[0] / sigmas[2] == pytest.approx(1.0 / (0.177 + 0.000823 * DRYDEN_HEIGHT_M / FEET) ** 0.4)


def test_the_gusts_follow_the_seed_and_the_steps_alone():
    mean = (0.0, 5.0, 0.0)
    first, again = wind_series(WindModel(mean, 1.5, 3)), wind_series(WindModel(mean, 1.5, 3))
    other = wind_series(WindModel(mean, 1.5, 4))
    assert np.array_equal(first, again) and not np.array_equal(first, other)
    calm = wind_series(WindModel(mean, 0.0, 3))
    assert np.all(calm == np.array(mean))
    reseeded = WindModel(mean, 1.5, 4)
    reseeded.set(Wind(0.0, -5.0, 1.5, 3))
    assert np.array_equal(wind_series(reseeded), first)


def wind_series(model: WindModel, steps: int = 2000) -> np.ndarray:
    return np.array([model.step(DT).copy() for _ in range(steps)])


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
    assert service.values() == {"SIH_WIND_N": -3.0, "SIH_WIND_E": -4.0, "SIM_WIND_TURB": 0.0, "SIM_WIND_SEED": 0.0}
    listed = service.answer(M.MAVLink_param_request_list_message(1, 200))
    assert [v.param_id for v in listed.values] == list(BY_NAME) and listed.values[0].param_count == 4
    answer = service.answer(param_set("SIH_WIND_N", 0.0))
    assert answer.values[0].param_value == 0.0 and not answer.said[0][1]
    assert service.wind_model.mean_ned == pytest.approx([0.0, 4.0, 0.0], abs=1e-12)
    answer = service.answer(param_set("SIM_WIND_SEED", 42))
    assert service.wind_model.seed == 42 and answer.values[0].param_value == encode(BY_NAME["SIM_WIND_SEED"], 42)


@pytest.mark.parametrize("message, why", [
    (param_set("SIH_WIND_E", 99.0), "SIH_WIND_E: 99 outside -40..40"),
    (param_set("SIH_WIND_E", math.nan), "not a finite number"),
    (param_set("SIM_WIND_TURB", 1.0, kind=6), "type 6, need 9"),
])  # fmt: skip
def test_a_refused_set_answers_the_unchanged_value_and_says_why(message, why):
    service = plant_service()
    answer = service.answer(message)
    assert answer.values[0].param_value == encode(BY_NAME[message.param_id], service.values()[message.param_id])
    assert why in answer.said[0][0] and answer.said[0][1] and service.wind_model.mean_ned[1] == 4.0


def test_a_request_for_others_or_an_unknown_name_changes_nothing():
    service = plant_service()
    assert service.answer(param_set("SIH_WIND_N", 9.0, target=(2, 200))).values == []
    unknown = M.MAVLink_param_set_message(1, 200, b"SIM_WIND_X", 1.0, 9)
    assert service.answer(unknown).values == [] and "unknown" in service.answer(unknown).said[0][0]
    assert service.values()["SIH_WIND_N"] == -3.0


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
    params.set("SIH_WIND_N", 3.0)  # before the plant has answered: not sent (the plant's own value wins)
    sync.step(0)
    sync.step(RESEND_USEC - 1)
    assert link.requests == 1 and link.sets == []
    sync.step(RESEND_USEC)  # no answer: asked again
    assert link.requests == 2
    for name, v in (("SIH_WIND_N", 5.0), ("SIH_WIND_E", -2.0), ("SIM_WIND_TURB", 0.0), ("SIM_WIND_SEED", 0)):
        assert sync.answered(value(name, v)) is None
    assert params["SIH_WIND_N"] == 5.0 and params["SIH_WIND_E"] == -2.0
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
    params.set("SIH_WIND_N", 7.0)
    params.set("MIS_TAKEOFF_ALT", 5.0)
    params.flush()
    assert "SIH_WIND" not in path.read_text()
    path.write_text('{"format": "tiltrotor-sitl parameters", "version": 1, "parameters": {"SIH_WIND_N": 7}}')
    reloaded = ParameterStore(path)
    reloaded.load()
    assert reloaded["SIH_WIND_N"] == 0.0 and "the plant keeps it" in reloaded.warnings[0]


def test_a_campaigns_wind_goes_to_the_plant(tmp_path):
    spec = {"scenario": "accel", "fixed": {"SIH_WIND_E": 6.0, "wind_d_mps": 0.5}, "axes": {"SIM_WIND_SEED": [1, 2]}}
    parse_campaign(spec, "gusts", tmp_path)
    wind, turbulence, seed = plant_wind({"SIH_WIND_E": 6.0, "wind_d_mps": 0.5, "SIM_WIND_TURB": 1.5,
                                         "SIM_WIND_SEED": 2})  # fmt: skip
    assert wind == pytest.approx((0.0, -6.0, 0.5), abs=1e-12) and (turbulence, seed) == (1.5, 2)
    assert scenario_parameters({"SIH_WIND_E": 6.0, "SIM_WIND_SEED": 2, "wind_d_mps": 0.5, "duration_s": 3}) == {
        "duration_s": 3
    }
    with pytest.raises(CampaignError, match="SIM_WIND_TURB: 20 outside 0..10"):
        parse_campaign({"scenario": "accel", "axes": {"SIM_WIND_TURB": [1, 20]}}, "x", tmp_path)


def test_vtol_up_gives_the_plant_its_wind(capsys):
    args = parser().parse_args(["up", "--wind", "5,-2", "--wind-turbulence", "1.5", "--wind-seed", "3"])
    plant, _ = up_commands(args, 0, 1)
    wind = next(arg for arg in plant if arg.startswith("--wind="))
    assert [float(v) for v in wind.removeprefix("--wind=").split(",")] == [-5.0, 2.0, 0.0]  # from N and from W
    assert plant[plant.index("--wind-turbulence") + 1] == "1.5" and plant[plant.index("--wind-seed") + 1] == "3"
    assert not any(arg.startswith("--wind") for arg in up_commands(parser().parse_args(["up"]), 0, 1)[0])
    with pytest.raises(SystemExit) as refused:
        up_commands(parser().parse_args(["up", "--wind", "50,0"]), 0, 1)
    assert refused.value.code == 2 and "SIH_WIND_N: 50 outside -40..40" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        parser().parse_args(["up", "--wind", "5"])
    assert "expected N,E" in capsys.readouterr().err
