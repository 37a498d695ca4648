"""Benchmark the MuJoCo bridge: MuJoCo steps per second with N muscles, against MuJoCo alone.

N masses hanging from N muscles (mpam97, the calibrated law, valves open-loop shut at 0.4 MPa),
one model; each step is ``MuscleBank.step`` (``mj_step1``, the muscles' exchange, ``mj_step2``,
the chambers' RK4 step in blocks of 64 lanes) against ``mj_step`` of the same model with the
controls held. Also the endoscope (13 discs, three muscles under their controllers) per 1 ms
control period.

Run: python benchmarks/bench_mujoco.py
"""

from __future__ import annotations

import time

import mujoco

from mckibben.export.mujoco import MuscleBank, muscle_plant


def many_masses(n: int, plant, timestep: float = 1e-4) -> str:
    """MJCF of n masses, each hanging from its own muscle (tendons muscle0..muscle{n-1})."""
    l0 = float(plant.nominal_length)
    bodies, tendons, acts = [], [], []
    for i in range(n):
        x = 0.01 * i
        bodies.append(f'<site name="a{i}" pos="{x} 0 0"/><body pos="{x} 0 {-l0}"><joint type="slide" axis="0 0 1" '
                      f'damping="4"/><geom type="sphere" size="0.003" mass="0.066" contype="0" conaffinity="0"/>'
                      f'<site name="b{i}"/></body>')
        tendons.append(f'<spatial name="muscle{i}"><site site="a{i}"/><site site="b{i}"/></spatial>')
        acts.append(f'<general tendon="muscle{i}" gear="-1"/>')
    return (f'<mujoco><option timestep="{timestep}"/><worldbody>{"".join(bodies)}</worldbody>'
            f'<tendon>{"".join(tendons)}</tendon><actuator>{"".join(acts)}</actuator></mujoco>')


def rate(step, seconds: float = 1.0) -> float:
    """Calls of ``step`` per second, over about ``seconds`` (best of three)."""
    best = 0.0
    for _ in range(3):
        k, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds / 3:
            for _ in range(100):
                step()
            k += 100
        best = max(best, k / (time.perf_counter() - t0))
    return best


def main():
    plant = muscle_plant("mpam97")
    print(f"{'muscles':>8} {'MuJoCo alone':>14} {'with muscles':>14} {'per muscle-step':>16}")
    for n in (1, 3, 16, 64, 256):
        model = mujoco.MjModel.from_xml_string(many_masses(n, plant))
        data = mujoco.MjData(model)
        bank = MuscleBank(model, [f"muscle{i}" for i in range(n)], plant, initial_pressure=0.4e6)
        bank.step(data)  # compile/load the kernels
        alone = rate(lambda: mujoco.mj_step(model, data))
        data2 = mujoco.MjData(model)
        both = rate(lambda: bank.step(data2))
        extra = (1 / both - 1 / alone) / n
        print(f"{n:>8} {alone:>12,.0f}/s {both:>12,.0f}/s {extra * 1e6:>13.2f} us")
    endoscope()


def endoscope():
    """The endoscope of tool track --engine mujoco: steps per second, and seconds per simulated second."""
    from mckibben.control.core import core_spec
    from mckibben.tool import make_tool
    from mckibben.tool.mujoco_model import endoscope_mjcf
    from mckibben.tool.tracking import tracking_setup, tip_reference, resolve_path
    from mckibben.tool.paths import parse_path

    tool = make_tool()
    ref = tip_reference(tool, resolve_path(parse_path("circle:radius=5mm,period=4s,cycles=0.25"), tool))
    _, params, _, _ = tracking_setup(tool, ref)
    model = mujoco.MjModel.from_xml_string(endoscope_mjcf(tool))
    data = mujoco.MjData(model)
    plant = muscle_plant(tool.muscle, "empirical", friction_force=0.0, friction_per_pa=0.0, passive_stiffness=0.0)
    bank = MuscleBank(model, ["muscle1", "muscle2", "muscle3"], plant, controller=core_spec(params, 3),
                      initial_pressure=ref.pressures[0], pressure_floor=0.3e6)
    bank.step(data, reference=ref.pressures[0])
    data2 = mujoco.MjData(model)
    alone = rate(lambda: mujoco.mj_step(model, data2))
    both = rate(lambda: bank.step(data))
    print(f"endoscope (13 discs, 3 muscles, controllers at 1 kHz): MuJoCo alone {alone:,.0f} steps/s, with the "
          f"muscles {both:,.0f} steps/s = {1e-4 * both:.2f} simulated s per s at 0.1 ms")


if __name__ == "__main__":
    main()
