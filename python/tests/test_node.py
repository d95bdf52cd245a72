"""Nodes over Zenoh on 127.0.0.1: two modules in one process, reports, plans and their
acknowledgements, errors, closing."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator

import pytest

import slate

from .conftest import free_endpoint, run_with_timeout

WORLD = """
class Vehicle {
    speed: real [m/s] in 0 .. 10 = 0.0;
    mode: string = "auto";
}
"""


def eventually(condition: Callable[[], bool], seconds: float = 10.0) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return condition()


@pytest.fixture
def pair() -> Iterator[tuple[slate.Node, slate.Node]]:
    """t/r1/nav (owns gsr, listens) and t/r2/loco (connects), both exporting everything."""
    endpoint = free_endpoint()
    nav_board = slate.Board(address="t/r1/nav")
    nav_board.load(WORLD + "object gsr : Vehicle context self;")
    loco_board = slate.Board(address="t/r2/loco")
    loco_board.load(WORLD)
    # Each may send the other plans (by default a node takes them from its robot only).
    nav = slate.Node(
        "t/r1/nav", nav_board, listen=[endpoint], export=["Thing"], plans_from=["robot", "t/r2/loco"]
    )
    loco = slate.Node(
        "t/r2/loco", loco_board, connect=[endpoint], export=["Thing"], plans_from=["robot", "t/r1/nav"]
    )
    try:
        assert eventually(lambda: nav.peers() == ["t/r2/loco"] and loco.peers() == ["t/r1/nav"])
        yield nav, loco
    finally:
        loco.close()
        nav.close()


def test_a_write_on_one_node_is_visible_on_the_other(pair: tuple[slate.Node, slate.Node]) -> None:
    nav, loco = pair

    def check() -> None:
        assert eventually(lambda: "gsr" in loco.board)
        nav.board.write("gsr", "speed", 2.5, accuracy=0.1, confidence=0.9)
        assert eventually(lambda: loco.board.read("gsr", "speed").value == 2.5)
        p = loco.board.read("gsr", "speed")
        assert p.source == "t/r1/nav"
        assert p.confidence == pytest.approx(0.9, abs=0.01)
        # And the other way: loco writes, nav sees it.
        loco.board.write("gsr", "mode", "manual")
        assert eventually(lambda: nav.board.read("gsr", "mode").value == "manual")

    run_with_timeout(check)


def test_a_function_run_on_a_network_thread_keeps_that_threads_python_state(
    pair: tuple[slate.Node, slate.Node],
) -> None:
    """An on-write function runs on the thread that merged the report (one of Zenoh's, or
    the node's delivery thread): that thread keeps its Python state from one call to the
    next, as a Python thread does, instead of a state made and destroyed around each call
    (its `threading.local` data then lasted one call)."""
    nav, loco = pair
    local = threading.local()
    calls: dict[int, list[int]] = {}

    def count(call: slate.Call) -> None:
        local.n = getattr(local, "n", 0) + 1
        calls.setdefault(threading.get_ident(), []).append(local.n)

    loco.board.on_write("Vehicle", "speed", count)

    def check() -> None:
        assert eventually(lambda: "gsr" in loco.board)
        # Until one thread merged two reports (the team link sends one per 200 ms).
        deadline = time.monotonic() + 10.0
        i = 0
        while time.monotonic() < deadline and max(map(len, calls.values()), default=0) < 2:
            i += 1
            nav.board.write("gsr", "speed", (i % 40) / 4)
            time.sleep(0.02)
        assert max(map(len, calls.values()), default=0) >= 2, calls
        assert threading.get_ident() not in calls, calls
        assert all(seq == list(range(1, len(seq) + 1)) for seq in calls.values()), calls

    run_with_timeout(check)


def team_reports_sent(node: slate.Node) -> int:
    """Reports the node sent on the team link, from its counters."""
    rows = node.stats()["traffic"]
    return sum(r["sent_msgs"] for r in rows if r["link"] == "team" and r["kind"] == "report")


def test_a_burst_of_writes_costs_the_team_link_a_few_reports_and_the_last_value_arrives(
    pair: tuple[slate.Node, slate.Node],
) -> None:
    # A Python node starts from the same settings as `slate node`: an attribute goes on
    # the team link at most every 200 ms, with its last value at the trailing edge.
    nav, loco = pair

    def check() -> None:
        assert eventually(lambda: "gsr" in loco.board)
        before = team_reports_sent(nav)
        for i in range(1, 101):
            nav.board.write("gsr", "speed", i / 10.0)
        assert eventually(lambda: loco.board.read("gsr", "speed").value == 10.0)
        sent = team_reports_sent(nav) - before
        assert 0 < sent < 20, f"{sent} reports for 100 writes"

    run_with_timeout(check)


def test_send_plan_yields_every_acknowledgement_as_it_arrives(
    pair: tuple[slate.Node, slate.Node],
) -> None:
    nav, loco = pair
    plan = """plan slow {
        trigger: gsr.speed > 5.0;
        termination: gsr.mode == "slow";
        action { set gsr.mode = "slow"; }
    }"""

    def check() -> None:
        assert eventually(lambda: "gsr" in loco.board)
        handle = loco.send_plan(plan, to="t/r1/nav")
        assert (handle.name, handle.to, handle.circuit) == ("slow", "t/r1/nav", 1)
        assert repr(handle) == "PlanHandle(circuit=1, name='slow', to='t/r1/nav')"
        steps = []
        for ack in handle.acks:
            steps.append(ack.step)
            if ack.step == "initiated":
                nav.board.write("gsr", "speed", 6.0)
        assert steps == ["received", "accepted", "initiated", "triggered", "terminated"]
        assert handle.done
        assert handle.get(timeout=0.1) is None
        assert nav.board.plan("slow").state == "terminated"
        snap = nav.snapshot()
        assert [p["acks"] for p in snap["plans"] if p["name"] == "slow"] == [
            ["received", "accepted", "initiated", "triggered ok: fired 1", "terminated"]
        ]

    run_with_timeout(check)


def test_a_plan_the_destination_cannot_load_is_rejected_with_the_reason(
    pair: tuple[slate.Node, slate.Node],
) -> None:
    nav, loco = pair

    def check() -> None:
        handle = loco.send_plan("plan bad { trigger: gsr.sped > 1.0; action { } }", to="t/r1/nav")
        first = handle.get(timeout=10)
        assert first is not None and first.step == "received"
        rejected = handle.get(timeout=10)
        assert rejected is not None
        assert (rejected.step, rejected.ok, rejected.last) == ("rejected", False, True)
        assert "no attribute sped" in rejected.detail
        assert handle.get(timeout=0.1) is None

    run_with_timeout(check)


def test_a_plan_from_a_module_without_authority_is_rejected_with_the_reason() -> None:
    endpoint = free_endpoint()
    nav_board = slate.Board(address="t/r1/nav")
    nav_board.load(WORLD + "object gsr : Vehicle context self;")
    nav = slate.Node("t/r1/nav", nav_board, listen=[endpoint])
    evil = slate.Node("t/r9/evil", connect=[endpoint])
    try:

        def check() -> None:
            assert eventually(lambda: "t/r9/evil" in nav.peers())
            pwn = 'plan pwn { action { set gsr.mode = "pwned"; } }'
            handle = evil.send_plan(pwn, to="t/r1/nav")
            steps = [handle.get(timeout=10) for _ in range(2)]
            assert [s.step for s in steps if s] == ["received", "rejected"]
            assert steps[1] and "t/r9/evil may not send plans to t/r1/nav" in steps[1].detail
            assert nav.board.read("gsr", "mode").value == "auto"
            assert nav.snapshot()["summary"]["plans refused: no authority"] == 1
            with pytest.raises(ValueError, match="plans_from"):
                slate.Node("t/r1/other", plans_from=["everyone"])

        run_with_timeout(check)
    finally:
        evil.close()
        nav.close()


def test_a_write_the_boards_rules_keep_from_its_writer_is_refused_with_an_event() -> None:
    # `writes=` is `[authority.writes]`: only nav's own robot may write a Vehicle's mode
    # on nav's board. Loco, on another robot, writes both attributes: the speed arrives,
    # the mode is refused with an `unauthorised` event naming the rule.
    endpoint = free_endpoint()
    nav_board = slate.Board(address="t/r1/nav")
    nav_board.load(WORLD + "object gsr : Vehicle context system;")
    events = nav_board.events()
    nav = slate.Node("t/r1/nav", nav_board, listen=[endpoint], export=["Thing"], writes={"Vehicle.mode": ["robot"]})
    loco_board = slate.Board(address="t/r2/loco")
    loco_board.load(WORLD)
    loco = slate.Node("t/r2/loco", loco_board, connect=[endpoint], export=["Thing"])
    try:

        def check() -> None:
            assert eventually(lambda: "gsr" in loco.board)
            loco.board.write("gsr", "mode", "stolen")
            loco.board.write("gsr", "speed", 3.0)
            assert eventually(lambda: nav.board.read("gsr", "speed").value == 3.0)
            assert nav.board.read("gsr", "mode").value == "auto"
            refused = [e for e in events.drain() if e.kind == "unauthorised"]
            assert refused and refused[0].attr == "mode", refused
            with pytest.raises(ValueError, match="writes"):
                slate.Node("t/r1/other", writes={"Vehicle.mode": ["everyone"]})
            with pytest.raises(slate.NodeError, match="Nothing"):
                slate.Node("t/r1/other", writes={"Nothing": ["robot"]})

        run_with_timeout(check)
    finally:
        loco.close()
        nav.close()


def test_cancel_a_plan_from_its_handle(pair: tuple[slate.Node, slate.Node]) -> None:
    nav, loco = pair

    def check() -> None:
        handle = loco.send_plan("plan idle { trigger: gsr.speed > 9.0; action { } }", to="t/r1/nav")
        assert [handle.get(timeout=10).step for _ in range(3)] == [  # type: ignore[union-attr]
            "received",
            "accepted",
            "initiated",
        ]
        handle.cancel()
        last = handle.get(timeout=10)
        assert last is not None and last.step == "cancelled"
        assert nav.board.plan("idle").state == "cancelled"

    run_with_timeout(check)


HOLD = """plan hold {
    trigger: gsr.mode == "go";
    termination: gsr.mode == "done";
    action { set gsr.mode = "going"; }
}"""


def lose_the_destination(nav: slate.Node, loco: slate.Node) -> slate.PlanHandle:
    """Sends HOLD from nav to loco, takes its first three acks, closes loco, and returns
    the handle once it has delivered `destination_lost`."""
    assert eventually(lambda: "gsr" in loco.board)
    handle = nav.send_plan(HOLD, to="t/r2/loco")
    assert [handle.get(timeout=10).step for _ in range(3)] == [  # type: ignore[union-attr]
        "received",
        "accepted",
        "initiated",
    ]
    loco.close()
    lost = handle.get(timeout=10)
    assert lost is not None
    assert (lost.step, lost.ok, lost.last) == ("destination_lost", False, False)
    return handle


def test_a_lost_destination_is_not_the_last_acknowledgement(
    pair: tuple[slate.Node, slate.Node],
) -> None:
    """The circuit stays open after `destination_lost` (the destination may come back):
    the handle is not done, and waits on for more."""
    nav, loco = pair

    def check() -> None:
        handle = lose_the_destination(nav, loco)
        assert not handle.done
        assert handle.get(timeout=0.2) is None
        assert not handle.done, "a wait that times out is not the end"

    run_with_timeout(check)


def test_acknowledgements_go_on_after_the_destination_restarts(
    pair: tuple[slate.Node, slate.Node],
) -> None:
    """A `destination_lost` ack is not the last: the circuit sends the plan again when the
    destination is back, and its acknowledgements resume on the same handle."""
    nav, loco = pair

    def check() -> None:
        handle = lose_the_destination(nav, loco)
        board = slate.Board(address="t/r2/loco")
        board.load(WORLD)
        again = slate.Node(
            "t/r2/loco", board, connect=nav.listening, export=["Thing"], plans_from=["robot", "t/r1/nav"]
        )
        try:
            nav.board.write("gsr", "mode", "go")
            assert eventually(lambda: nav.board.read("gsr", "mode").value == "going", 20)
            nav.board.write("gsr", "mode", "done")
            steps = []
            while (ack := handle.get(timeout=20)) is not None:
                steps.append(ack.step)
            assert steps[-2:] == ["triggered", "terminated"], steps
            assert handle.done
        finally:
            again.close()

    run_with_timeout(check, 60)


def test_bad_arguments_raise_what_is_wrong() -> None:
    with pytest.raises(slate.AddressError):
        slate.Node("nav")
    with pytest.raises(slate.NodeError, match="the board is t/r1/other but the node is t/r1/nav"):
        slate.Node("t/r1/nav", slate.Board(address="t/r1/other"))
    with pytest.raises(ValueError, match="mode 'mesh'"):
        slate.Node("t/r1/nav", mode="mesh")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="interest"):
        slate.Node("t/r1/nav", interest=["Obstacle:nearby"])
    with pytest.raises(ValueError, match="dashboard"):
        slate.Node("t/r1/nav", dashboard="localhost")
    with slate.Node("t/r1/alone", listen=[free_endpoint()]) as n:
        with pytest.raises(slate.PlanError, match="not one plan"):
            n.send_plan("class C { x: real; }", to="t/r1/other")
        with pytest.raises(slate.AddressError):
            n.send_plan("plan p { action { } }", to="nowhere")


def test_a_node_closes_once_and_says_so() -> None:
    with slate.Node("t/r1/solo", listen=[free_endpoint()], dashboard="127.0.0.1:0") as n:
        assert repr(n) == "Node('t/r1/solo')"
        assert n.address == "t/r1/solo"
        assert n.board.address == "t/r1/solo"
        assert n.listening[0].startswith("tcp/127.0.0.1:")
        assert n.dashboard_url is not None and n.dashboard_url.startswith("http://127.0.0.1:")
        assert n.peers() == []
        assert n.snapshot()["title"] == "slate node t/r1/solo"
    assert n.closed
    assert n.dashboard_url is None
    n.close()
    assert repr(n) == "Node('t/r1/solo', closed)"
    with pytest.raises(slate.PlanError, match="closed"):
        n.send_plan("plan p { action { } }", to="t/r1/x")


@pytest.mark.parametrize("key", ["connect", "listen"])
def test_a_malformed_endpoint_is_a_value_error_that_shows_the_form(key: str) -> None:
    with pytest.raises(ValueError, match=r"bogus.*PROTOCOL/ADDRESS.*tcp/127\.0\.0\.1:7447") as e:
        slate.Node("t/r1/nav", **{key: ["bogus"]})  # type: ignore[arg-type]
    assert "Json5Err" not in str(e.value) and ".cargo" not in str(e.value)
    assert key in str(e.value)


def test_a_second_node_on_one_board_or_address_is_refused_while_the_first_is_open() -> None:
    board = slate.Board(address="t/r1/twice")
    with slate.Node("t/r1/twice", board, listen=[free_endpoint()]):
        with pytest.raises(slate.NodeError, match="board already has an open node"):
            slate.Node("t/r1/twice", board, listen=[free_endpoint()])
        with pytest.raises(slate.NodeError, match="t/r1/twice is already open"):
            slate.Node("t/r1/twice", listen=[free_endpoint()])
    # Once the first is closed, both are free again.
    with slate.Node("t/r1/twice", board, listen=[free_endpoint()]) as again:
        assert again.board.address == "t/r1/twice"


def test_a_class_two_nodes_define_differently_is_an_event_on_both() -> None:
    endpoint = free_endpoint()
    nav_board = slate.Board(address="t/r1/nav")
    nav_board.load("class Sonar { ping: real; }\nobject s1 : Sonar context self { ping = 0.5; }")
    loco_board = slate.Board(address="t/r2/loco")
    loco_board.load("class Sonar { ping: int; }\nobject s2 : Sonar context self { ping = 3; }")
    nav_events = nav_board.events(timeout=0.0)
    loco_events = loco_board.events(timeout=0.0)
    with (
        slate.Node("t/r1/nav", nav_board, listen=[endpoint], export=["Thing"]),
        slate.Node("t/r2/loco", loco_board, connect=[endpoint], export=["Thing"]),
    ):
        seen: dict[str, list[slate.Event]] = {"nav": [], "loco": []}

        def both_report() -> bool:
            seen["nav"] += nav_events.drain()
            seen["loco"] += loco_events.drain()
            return all(any(e.kind == "class_conflict" for e in got) for got in seen.values())

        assert eventually(both_report), seen
    conflict = next(e for e in seen["nav"] if e.kind == "class_conflict")
    assert conflict.object == "Sonar" and conflict.source == "t/r2/loco"
    assert "defined differently" in (conflict.error or "")


OWNED = "class Vehicle { heading: real merge owned; speed: real; }\n"


def test_a_write_of_an_owned_attribute_by_another_module_is_a_not_owner_event() -> None:
    # evil's board says it owns gsr (as a module that lies would) and writes gsr's owned
    # heading; nav owns gsr on loco's board. evil starts last, listening where loco
    # already connects, so that loco hears it at once.
    endpoint, evils = free_endpoint(), free_endpoint()
    boards = {name: slate.Board(address=name) for name in ["t/r1/nav", "t/r2/loco", "t/r1/evil"]}
    boards["t/r1/nav"].load(OWNED + "object gsr : Vehicle;")
    boards["t/r2/loco"].load(OWNED)
    boards["t/r1/evil"].load(OWNED + "object gsr : Vehicle;")
    loco = boards["t/r2/loco"]
    events = loco.events(timeout=0.0)
    seen: list[slate.Event] = []
    with (
        slate.Node("t/r1/nav", boards["t/r1/nav"], listen=[endpoint], export=["Thing"]),
        slate.Node("t/r2/loco", loco, connect=[endpoint, evils], export=["Thing"]),
    ):
        boards["t/r1/nav"].write("gsr", "heading", 1.0)
        assert eventually(lambda: "gsr" in loco and loco.read("gsr", "heading").value == 1.0)
        evil = slate.Node(
            "t/r1/evil", boards["t/r1/evil"], listen=[evils], connect=[endpoint], export=["Thing"]
        )
        with evil:

            def refused() -> bool:
                boards["t/r1/evil"].write("gsr", "heading", 9.0)
                seen.extend(events.drain())
                return any(e.kind == "not_owner" for e in seen)

            assert eventually(refused), seen
        assert loco.read("gsr", "heading").value == 1.0
    event = next(e for e in seen if e.kind == "not_owner")
    assert (event.object, event.attr, event.source) == ("gsr", "heading", "t/r1/evil")
    assert "t/r1/nav" in (event.error or "") and event.suppressed is not None
    assert all(e.kind != "other" for e in seen), seen


def test_packets_from_a_module_whose_clock_is_years_ahead_are_refused_and_reported() -> None:
    endpoint = free_endpoint()
    ahead = slate.Clock("manual")
    ahead.set(time.time() + 3 * 365 * 86400.0)
    nav_board = slate.Board(clock=ahead, address="t/r1/nav")
    nav_board.load(WORLD + "object gsr : Vehicle context self;")
    loco_board = slate.Board(address="t/r2/loco")
    loco_board.load(WORLD)
    events = loco_board.events(timeout=0.0)
    with (
        slate.Node("t/r1/nav", nav_board, listen=[endpoint], export=["Thing"]),
        slate.Node("t/r2/loco", loco_board, connect=[endpoint], export=["Thing"]),
    ):
        seen: list[slate.Event] = []

        def refused() -> bool:
            nav_board.write("gsr", "speed", 3.0)
            seen.extend(events.drain())
            return any(e.kind == "future_stamp" for e in seen)

        assert eventually(refused), seen
        # Loco holds no packet from the future, which would freeze the value.
        if "gsr" in loco_board:
            assert loco_board.read("gsr", "speed").timestamp < time.time() + 1.0
    event = next(e for e in seen if e.kind == "future_stamp")
    assert event.source == "t/r1/nav" and event.attr == "speed"
