"""Reward, social cost, choice and saturation updates of the motivator, against hand-computed values."""

from __future__ import annotations

import itertools
import math

import pytest
from pydantic import ValidationError

from cyborg.emotion.model import PAD
from cyborg.motivator.logic import (
    DecisionStatus,
    MotivationalEvent,
    MotivatorSettings,
    SelectionRule,
    apply_choice,
    choose,
    decline,
    event_cost,
    event_reward,
    is_ready,
    should_reset,
)


def ev(name: str, p: float = 0.0, a: float = 0.0, d: float = 0.0, **kw: object) -> MotivationalEvent:
    return MotivationalEvent.model_validate(
        {"state": "idle", "event": name, "reward_pleasure": p, "reward_arousal": a}
        | {"reward_dominance": d}
        | kw
    )


NAVIGATION = ev("navigation_emotional", 0.0, 0.05, -0.01)


# --- reward and cost -----------------------------------------------------------------------


def test_reward_at_neutral_mood() -> None:
    # sigma = (0 + 1) / 2 = 0.5 for every drive, p = 1 - 0.125 = 0.875
    # d = reward / 2 = (0, 0.025, -0.005);  R = 0.875 * (0.025 - 0.005) = 0.0175
    assert event_reward(PAD(), NAVIGATION) == pytest.approx(0.0175)


def test_reward_weights_each_drive_by_its_priority() -> None:
    # sigma = (0.8, 0.4, 1.0);  p = (1 - 0.512, 1 - 0.064, 1 - 1) = (0.488, 0.936, 0)
    # d = (0.05, 0.10, 0.15);  R = 0.488*0.05 + 0.936*0.10 + 0*0.15 = 0.0244 + 0.0936 = 0.118
    assert event_reward(PAD(0.6, -0.2, 1.0), ev("x", 0.1, 0.2, 0.3)) == pytest.approx(0.118)


def test_cost_grows_with_the_cube_root_of_saturation() -> None:
    event = ev("x", 0.1, 0.2, 0.3)  # sum of d = 0.05 + 0.10 + 0.15 = 0.3
    assert event_cost(0.0, event) == 0.0
    assert event_cost(0.125, event) == pytest.approx(0.15)  # cbrt(0.125) = 0.5 -> 0.5 * 0.3
    assert event_cost(1.0, event) == pytest.approx(0.3)


# --- choose --------------------------------------------------------------------------------

A = ev("a_many", 0.1, 0.1, 0.1)  # R at neutral = 0.875 * 0.15 = 0.13125
B = ev("b_pleasure", 0.2, 0.0, 0.0)  # R at neutral = 0.875 * 0.10 = 0.0875


def test_net_rule_prefers_the_fresh_event() -> None:
    # A: saturation 0.343, cbrt = 0.7, cost = 0.7 * 0.15 = 0.105, net = 0.02625
    # B: saturation 0, cost 0, net = 0.0875
    decision = choose(PAD(), [A, B], {"a_many": 0.343}, state="idle")
    assert decision.status is DecisionStatus.CHOSEN
    assert decision.chosen == B
    by_name = {c.event.event: c for c in decision.candidates}
    assert by_name["a_many"].reward == pytest.approx(0.13125)
    assert by_name["a_many"].cost == pytest.approx(0.105)
    assert by_name["a_many"].net == pytest.approx(0.02625)
    assert all(c.eligible for c in decision.candidates)


def test_reward_rule_prefers_the_larger_reward() -> None:
    decision = choose(PAD(), [A, B], {"a_many": 0.343}, rule=SelectionRule.REWARD)
    assert decision.chosen == A


def test_event_whose_cost_reaches_its_reward_is_not_eligible() -> None:
    # A at saturation 1: cost = 1 * 0.15 = 0.15 > R = 0.13125
    decision = choose(PAD(), [A], {"a_many": 1.0}, state="idle")
    assert decision.status is DecisionStatus.NOT_WORTH_IT
    assert decision.chosen is None
    assert not decision.candidates[0].eligible
    assert "reward <= cost" in decision.reason and "a_many" in decision.reason


def test_negative_reward_is_never_chosen() -> None:
    decision = choose(PAD(), [ev("sulk", -0.1, -0.1, -0.1)], {})
    assert decision.chosen is None


def test_no_events_names_the_state() -> None:
    decision = choose(PAD(), [], {}, state="music")
    assert decision.status is DecisionStatus.NO_EVENTS
    assert decision.reason == "no motivational events in state 'music'"


def test_events_of_other_states_are_ignored_when_the_state_is_given() -> None:
    elsewhere = MotivationalEvent(state="conversation", event="joke_tell", reward_pleasure=0.5)
    decision = choose(PAD(), [elsewhere], {}, state="idle")
    assert decision.status is DecisionStatus.NO_EVENTS


def test_ties_go_to_the_alphabetically_first_event() -> None:
    decision = choose(PAD(), [ev("zebra", 0.1), ev("apple", 0.1)], {})
    assert decision.chosen is not None and decision.chosen.event == "apple"


def test_questions_rotate_with_the_net_rule_but_repeat_with_the_reward_rule() -> None:
    # Scenario D: several equally rewarding questions must not be asked twice in a row.
    settings = MotivatorSettings()
    questions = [ev(name, 0.02, 0.02) for name in ("joke", "selfie", "simon", "weather")]

    def run(rule: SelectionRule) -> list[str]:
        saturations: dict[str, float] = {}
        asked = []
        for _ in range(10):
            decision = choose(PAD(), questions, saturations, rule=rule)
            assert decision.chosen is not None
            asked.append(decision.chosen.event)
            saturations = apply_choice(saturations, decision.chosen, questions, settings)
        return asked

    net = run(SelectionRule.NET)
    assert all(x != y for x, y in itertools.pairwise(net))
    assert set(net) == {"joke", "selfie", "simon", "weather"}
    reward = run(SelectionRule.REWARD)
    assert reward[:2] == ["joke", "joke"]


# --- saturation updates ---------------------------------------------------------------------


def test_apply_choice_fills_the_chosen_and_relieves_the_others() -> None:
    settings = MotivatorSettings()  # increment 0.33, relief 0.05
    chosen = ev("a")
    others = [chosen, ev("b"), ev("c"), ev("d")]
    result = apply_choice({"a": 0.5, "b": 0.03, "c": 0.9}, chosen, others, settings)
    # a: 0.5 + 0.33 = 0.83; b: max(0, 0.03 - 0.05) = 0; c: 0.9 - 0.05 = 0.85; d: max(0, 0 - 0.05) = 0
    assert result == pytest.approx({"a": 0.83, "b": 0.0, "c": 0.85, "d": 0.0})


def test_event_cost_overrides_the_increment_and_is_capped_at_one() -> None:
    settings = MotivatorSettings()
    heavy = ev("a", event_cost=0.6)
    assert apply_choice({"a": 0.5}, heavy, [heavy], settings) == {"a": 1.0}  # 0.5 + 0.6 -> 1
    light = ev("a", event_cost=0.1)
    assert apply_choice({"a": 0.5}, light, [light], settings) == pytest.approx({"a": 0.6})


def test_decline_is_linear_in_time_and_floored() -> None:
    # a: 0.5 - 0.001 * 10 = 0.49;  b: 0.004 - 0.01 -> 0
    assert decline({"a": 0.5, "b": 0.004}, 10.0, 0.001) == pytest.approx({"a": 0.49, "b": 0.0})


@pytest.mark.parametrize("elapsed", [-0.5, math.nan])
def test_decline_rejects_bad_elapsed(elapsed: float) -> None:
    with pytest.raises(ValueError, match="elapsed_seconds"):
        decline({"a": 0.5}, elapsed, 0.001)


def test_readiness_and_reset() -> None:
    settings = MotivatorSettings(min_seconds_in_state=10.0, idle_reset_seconds=180.0)
    assert not is_ready(9.9, settings) and is_ready(10.0, settings)
    assert not should_reset(179.0, settings) and should_reset(180.0, settings)
    assert not should_reset(1e9, MotivatorSettings())


# --- settings -------------------------------------------------------------------------------


def test_default_settings() -> None:
    s = MotivatorSettings()
    assert (s.rate_seconds, s.saturation_increment, s.saturation_relief) == (2.0, 0.33, 0.05)
    assert s.selection is SelectionRule.NET
    assert s.increment_for(NAVIGATION) == 0.33


@pytest.mark.parametrize(
    ("data", "needle"),
    [
        ({"rate": 2}, "rate"),
        ({"rate_seconds": 0}, "rate_seconds"),
        ({"selection": "best"}, "selection"),
        (
            {"events": [{"state": "idle", "event": "x"}, {"state": "idle", "event": "x"}]},
            "'x' is listed twice for state 'idle'",
        ),
        ({"events": [{"state": "idle", "event": "two words"}]}, "whitespace"),
        ({"events": [{"state": "idle", "event": "x", "reward_arousal": 1.5}]}, "reward_arousal"),
        ({"events": [{"state": "idle", "event": "x", "event_cost": -0.1}]}, "event_cost"),
    ],
)
def test_bad_settings_are_explained(data: dict[str, object], needle: str) -> None:
    with pytest.raises(ValidationError, match=needle):
        MotivatorSettings.model_validate(data)
