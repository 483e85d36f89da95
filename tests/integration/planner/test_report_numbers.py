"""Reports are numbered; a gap makes the planner ask for the missing ones (issue 13).

A drone's reports of a leg carry numbers from 1 (``MissionProgress.seq``). Two reports are lost on
the way here (the drone keeps them, as it keeps every report, but they never reach the broker);
the next report shows the gap, the planner asks the drone for the leg's reports again, and at the
end the planner holds every number from 1 to the last (the ``completed`` report's) and every step.
"""

from __future__ import annotations

import pytest

from dronefleet.experiments.harness import Harness
from dronefleet.geo.types import NED
from dronefleet.ground.planner.models import Leg, MissionState
from dronefleet.ground.planner.options import MissionOptions
from dronefleet.ground.planner.progress import note_seq
from dronefleet.ground.planner.reconcile import missing
from dronefleet.messaging.missions import MissionProgress
from support.missions import fly_with_a_spare, small_field_steps

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]


def test_a_gap_is_seen_and_filled() -> None:
    leg = Leg(leg_id="L.1", drone_id="QUAD_A")
    assert not note_seq(leg, 1) and not note_seq(leg, 2)
    assert note_seq(leg, 5) and missing(leg.seqs) == [3, 4]
    assert note_seq(leg, 3) and not note_seq(leg, 4)
    assert leg.seqs == [1, 2, 3, 4, 5] and not note_seq(leg, 5)  # a duplicate changes nothing
    assert not note_seq(leg, None)


async def test_reports_lost_on_the_way_are_asked_for_and_every_number_arrives() -> None:
    options = MissionOptions(
        strategy="ours", collaboration=False, early_replacement=False, replacement=False
    )
    async with Harness(speedup=10) as h:
        mission_id = await fly_with_a_spare(h, small_field_steps(), options, spare_at=NED(10, 10))
        worker = h.fleet.apps["QUAD_A"].mission_worker
        post = worker.outbox.post
        lost: list[int] = []

        def lose_two(topic_name: str, message) -> None:
            seq = message.seq if isinstance(message, MissionProgress) else None
            if seq in (4, 5) and seq not in lost:  # the first sending; a replay goes through
                lost.append(seq)
                return
            post(topic_name, message)

        worker.outbox.post = lose_two
        record = await h.until_ended(mission_id, timeout_s=240)
    assert lost == [4, 5]
    assert record.state is MissionState.COMPLETED, record.error
    (leg,) = record.legs
    assert leg.seqs == list(range(1, leg.seqs[-1] + 1)) and leg.seqs[-1] >= 10
    assert len(record.done) == len(record.work)
