"""A navigation sensor module: dead reckoning with an uncertainty that grows, and fixes.

The module owns the vehicle's position on its board (address team/r1/nav). Between
landmark fixes it integrates speed and heading (dead reckoning), so the position's
accuracy (its standard deviation, in metres) grows with every step and its confidence
drops. A plan written in the slate language watches that accuracy: past 2 m it asks for a
fix and reports the position to the executive. A Python on-write function answers the
request by taking a landmark fix, which brings the accuracy back to 0.3 m, and a second
plan resumes dead reckoning.

Run it:  .venv/bin/python examples/python/sensor.py
"""

from __future__ import annotations

import math

import slate

WORLD = """
class Vehicle {
    position: vec<2> [m];
    heading: real [rad] = 0.0;
    speed: real [m/s] = 0.0;
    mode: string = "auto";                 // auto | needs_fix
}
object gsr : Vehicle context self;

// Dead reckoning drifts: past 2 m of uncertainty, ask for a fix and tell the executive.
plan ask_for_fix {
    trigger: gsr.position.accuracy > 2.0;
    action {
        set gsr.mode = "needs_fix";
        report gsr.position to "team/r1/exec";
    }
}

// Once a fix has come in, dead reckoning resumes.
plan resume {
    trigger: gsr.mode == "needs_fix" and gsr.position.accuracy < 1.0;
    action { set gsr.mode = "auto"; }
}
"""

DRIFT = 0.25  # metres of standard deviation gained per metre travelled
FIX_ACCURACY = 0.3  # a landmark fix is good to 0.3 m
STEP = 0.1  # seconds between position updates (10 Hz)


def confidence_for(accuracy: float) -> float:
    """How much to trust a position that may be `accuracy` metres off."""
    return max(0.1, min(1.0, 1.0 / (1.0 + accuracy)))


def main(steps: int = 120) -> int:
    nav = slate.Board(clock="manual", address="team/r1/nav")
    nav.load(WORLD)
    reports = nav.outgoing()
    positions = nav.watch("gsr", "position")
    fixes = []
    events = nav.events()

    @nav.on_write("Vehicle", "mode")
    def take_fix(call: slate.Call) -> None:
        """The plan asked for a fix: take one from a landmark (plan `resume` then clears
        the request; this function may not write `mode` itself, which would be a cycle)."""
        if call.packet.value != "needs_fix":
            return
        x, y = call.read(call.object, "position").value
        call.write(call.object, "position", [x, y], accuracy=FIX_ACCURACY, confidence=0.95)
        fixes.append(nav.clock.now())

    nav.write("gsr", "speed", 2.0, accuracy=0.05)
    nav.write("gsr", "heading", 0.3)
    nav.write("gsr", "position", [0.0, 0.0], accuracy=FIX_ACCURACY, confidence=0.95)

    worst = 0.0
    for _ in range(steps):
        nav.clock.advance(STEP)
        here = nav.read("gsr", "position")
        speed = nav.read("gsr", "speed").value
        heading = nav.read("gsr", "heading").value
        x, y = here.value
        step = speed * STEP
        accuracy = here.accuracy + DRIFT * step
        worst = max(worst, accuracy)
        nav.write(
            "gsr",
            "position",
            [x + step * math.cos(heading), y + step * math.sin(heading)],
            accuracy=accuracy,
            confidence=confidence_for(accuracy),
        )

    for e in events.drain():
        print(f"nav: {e.kind}: {e.error}")
    final = nav.read("gsr", "position")
    sent = reports.drain()
    seen = positions.drain()
    x, y = final.value
    print(f"nav: {steps} steps of {STEP} s at 2.0 m/s")
    print(f"nav: position ({x:.2f}, {y:.2f}) m, accuracy {final.accuracy:.2f} m, "
          f"confidence {final.confidence:.2f}")
    print(f"nav: accuracy grew to {worst:.2f} m between fixes")
    print(f"nav: {len(fixes)} landmark fixes, {len(sent)} reports to the executive")
    print(f"nav: a watcher saw {len(seen)} position changes")
    print(f"nav: plan ask_for_fix fired {nav.plan('ask_for_fix').fired} times")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
