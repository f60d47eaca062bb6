"""Hypothesis properties of the motivator's choice and saturation bookkeeping."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from cyborg.emotion.model import PAD
from cyborg.motivator.logic import (
    Candidate,
    DecisionStatus,
    MotivationalEvent,
    MotivatorSettings,
    SelectionRule,
    apply_choice,
    choose,
    decline,
)

unit = st.floats(-1.0, 1.0)
names = st.sampled_from(["joke", "music_play", "navigation_emotional", "selfie", "weather"])
events = st.lists(
    st.builds(
        MotivationalEvent,
        state=st.sampled_from(["idle", "conversation"]),
        event=names,
        reward_pleasure=unit,
        reward_arousal=unit,
        reward_dominance=unit,
    ),
    max_size=8,
)
saturations = st.dictionaries(names, st.floats(0.0, 1.0))
pads = st.builds(PAD, unit, unit, unit)


@given(pads, events, saturations, st.sampled_from(list(SelectionRule)))
def test_chosen_event_is_a_given_event_of_the_state_with_reward_above_cost(
    pad: PAD, given_events: list[MotivationalEvent], sat: dict[str, float], rule: SelectionRule
) -> None:
    decision = choose(pad, given_events, sat, state="idle", rule=rule)
    in_state = [e for e in given_events if e.state == "idle"]
    if decision.chosen is None:
        assert decision.status is not DecisionStatus.CHOSEN
        assert not any(c.eligible for c in decision.candidates)
        assert decision.reason
        return
    assert decision.status is DecisionStatus.CHOSEN
    assert decision.chosen in in_state
    winner = next(c for c in decision.candidates if c.event == decision.chosen)
    assert winner.reward > winner.cost

    def score(c: Candidate) -> float:
        return c.net if rule is SelectionRule.NET else c.reward

    assert all(score(winner) >= score(c) for c in decision.candidates if c.eligible)


@given(events, saturations, st.data())
def test_saturations_stay_in_the_unit_interval(
    given_events: list[MotivationalEvent], sat: dict[str, float], data: st.DataObject
) -> None:
    if not given_events:
        return
    chosen = data.draw(st.sampled_from(given_events))
    after = apply_choice(sat, chosen, given_events, MotivatorSettings())
    assert all(0.0 <= v <= 1.0 for v in after.values())
    assert after[chosen.event] >= sat.get(chosen.event, 0.0)
    declined = decline(after, data.draw(st.floats(0.0, 1e6)), 0.001)
    assert all(0.0 <= v <= after[k] for k, v in declined.items())
