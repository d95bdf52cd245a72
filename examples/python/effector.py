"""A locomotion module: an on-write active function drives the motors from a commanded speed.

The module's board (address team/r1/loco) holds the vehicle. Whoever commands a speed, a
planner module or a plan written in the slate language, writes `gsr.commanded_speed`; the
Python active function attached to `Vehicle.commanded_speed` reacts at once: it clamps the
command to what the motors can do, "drives" them, and writes back the speed reached and
the motor current. A command it cannot execute (negative) raises: the error is isolated,
reported as an event, and the board keeps working. A slate plan stops the vehicle when an
obstacle comes within 5 m, through the same active function.

Run it:  .venv/bin/python examples/python/effector.py
"""

from __future__ import annotations

import slate

WORLD = """
class Vehicle {
    commanded_speed: real [m/s] = 0.0;
    speed: real [m/s] in 0 .. 3 = 0.0;
    motor_current: real [A] = 0.0;
}
class Obstacle { range: real [m]; }
object gsr : Vehicle context self;

// Safety: an obstacle within 5 m stops the vehicle (through the on-write function below).
plan stop_near_obstacle {
    trigger: any o: Obstacle where o.range < 5.0;
    action { set gsr.commanded_speed = 0.0; }
}
"""

MAX_SPEED = 3.0  # m/s
AMPS_PER_MPS = 4.0


def main() -> int:
    loco = slate.Board(clock="manual", address="team/r1/loco")
    loco.load(WORLD)
    events = loco.events()
    log = []

    @loco.on_write("Vehicle", "commanded_speed")
    def drive(call: slate.Call) -> None:
        command: float = call.packet.value
        if command < 0.0:
            raise ValueError(f"cannot drive backwards at {command} m/s")
        speed = min(command, MAX_SPEED)
        call.write(call.object, "speed", speed, accuracy=0.05)
        call.write(call.object, "motor_current", speed * AMPS_PER_MPS, accuracy=0.1)
        log.append((command, speed))

    # A planner module commands speeds (an int is fine for a real attribute).
    for command in [1, 2.5, 7.0, -1.0, 2.0]:
        loco.clock.advance(0.5)
        try:
            loco.write("gsr", "commanded_speed", command, source="team/r1/planner")
        except slate.SlateError as e:
            print(f"loco: command refused: {e}")
        speed = loco.read("gsr", "speed").value
        print(f"loco: commanded {command} m/s -> driving at {speed} m/s")

    # The proximity sensor reports an obstacle 4 m ahead: the plan stops the vehicle.
    loco.create("Obstacle", "rock")
    loco.write("rock", "range", 4.0, accuracy=0.1)
    print(f"loco: obstacle at 4.0 m -> driving at {loco.read('gsr', 'speed').value} m/s")

    failures = [event for event in events.drain() if event.kind == "function_failed"]
    for failure in failures:
        print(f"loco: active function failed and was isolated: {failure.error}")
    current = loco.read("gsr", "motor_current").value
    print(f"loco: {len(log)} commands executed, motor current now {current} A")
    print(f"loco: plan stop_near_obstacle fired {loco.plan('stop_near_obstacle').fired} time")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
