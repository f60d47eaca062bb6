"""Reward, social cost, choice and saturation updates of the motivator, against hand-computed values."""

from __future__ import annotations

import itertools
import math

import pytest
from pydantic import ValidationError

from cyborg.app.config import load_config, packaged_config
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
    not_ready,
    should_reset,
    waiting_for_handover,
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


def test_the_reward_rule_takes_the_largest_reward_above_its_cost() -> None:
    # The thesis read literally: the largest reward among reward > cost (an option).
    # A: saturation 0.343, cbrt = 0.7, cost = 0.7 * 0.15 = 0.105 < R = 0.13125, net = 0.02625
    # B: saturation 0, cost 0, R = net = 0.0875 < 0.13125
    decision = choose(PAD(), [A, B], {"a_many": 0.343}, state="idle", rule=SelectionRule.REWARD)
    assert decision.status is DecisionStatus.CHOSEN
    assert decision.chosen == A
    by_name = {c.event.event: c for c in decision.candidates}
    assert by_name["a_many"].reward == pytest.approx(0.13125)
    assert by_name["a_many"].cost == pytest.approx(0.105)
    assert by_name["a_many"].net == pytest.approx(0.02625)
    assert all(c.eligible for c in decision.candidates)


def test_by_default_reward_minus_cost_ranks_so_a_just_used_event_gives_way() -> None:
    # After one choice A's saturation is the thesis's 0.33 (+0.013 left over): its net 0.026 is
    # below fresh B's 0.0875, so B comes next although A's reward is larger.
    decision = choose(PAD(), [A, B], {"a_many": 0.343})
    assert decision.chosen == B
    assert MotivatorSettings().selection is SelectionRule.NET


def test_event_whose_cost_reaches_its_reward_is_not_eligible() -> None:
    # A at saturation 1: cost = 1 * 0.15 = 0.15 > R = 0.13125
    decision = choose(PAD(), [A], {"a_many": 1.0}, state="idle")
    assert decision.status is DecisionStatus.NOT_WORTH_IT
    assert decision.chosen is None
    assert not decision.candidates[0].eligible
    assert "reward <= cost" in decision.reason and "a_many" in decision.reason


@pytest.mark.parametrize("saturation", [0.0, 0.5, 1.0])
def test_negative_reward_is_never_chosen(saturation: float) -> None:
    # sulk: R = 0.875 * -0.15 = -0.13125; at saturation 1 its cost is -0.15 < R, yet it must not pay
    decision = choose(PAD(), [ev("sulk", -0.1, -0.1, -0.1)], {"sulk": saturation})
    assert decision.chosen is None
    assert decision.status is DecisionStatus.NOT_WORTH_IT
    assert "reward <= 0" in decision.reason


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


def ask_ten_times(questions: list[MotivationalEvent], settings: MotivatorSettings) -> list[str]:
    saturations: dict[str, float] = {}
    asked = []
    for _ in range(10):
        decision = choose(PAD(), questions, saturations, rule=settings.selection)
        if decision.chosen is None:
            asked.append("-")
            continue
        asked.append(decision.chosen.event)
        saturations = apply_choice(saturations, decision.chosen, questions, settings)
    return asked


def test_the_reward_rule_repeats_a_question_until_its_cost_catches_up() -> None:
    # Four equally rewarding questions, event_cost 0.33: at a neutral mood R = 0.875 * sum(d), so a
    # question stays eligible while cbrt(saturation) < 0.875, i.e. saturation < 0.67: asked 2-3 times.
    questions = [ev(name, 0.02, 0.02) for name in ("joke", "selfie", "simon", "weather")]
    assert ask_ten_times(questions, MotivatorSettings(selection=SelectionRule.REWARD))[:2] == ["joke", "joke"]
    rotating = ask_ten_times(questions, MotivatorSettings())  # the default: reward - cost
    assert all(x != y for x, y in itertools.pairwise(rotating))
    assert set(rotating) == {"joke", "selfie", "simon", "weather"}


def test_a_high_event_cost_makes_questions_rotate_with_the_reward_rule() -> None:
    # event_cost 1 saturates a question at once (cost = sum(d) > R); relief 0.15 per other choice
    # brings it back below 0.67 after three others: 1 - 3 * 0.15 = 0.55.
    settings = MotivatorSettings(saturation_relief=0.15, selection=SelectionRule.REWARD)
    questions = [ev(name, 0.02, 0.02, event_cost=1.0) for name in ("joke", "selfie", "simon", "weather")]
    asked = ask_ten_times(questions, settings)
    assert "-" not in asked
    assert all(x != y for x, y in itertools.pairwise(asked))
    assert set(asked) == {"joke", "selfie", "simon", "weather"}


def test_the_default_robot_rotates_its_questions() -> None:
    # cyborg.yaml's conversation questions (thesis 10.2.4, scenario D) at a neutral mood, with
    # the thesis's saturation step and no event_cost of their own.
    settings = load_config(packaged_config("cyborg.yaml")).model.motivator
    questions = [e for e in settings.events if e.state == "conversation"]
    assert settings.selection is SelectionRule.NET and len(questions) == 5
    assert (settings.saturation_increment, settings.saturation_relief) == (0.33, 0.05)
    assert all(q.event_cost is None for q in questions)
    asked = ask_ten_times(questions, settings)
    assert "-" not in asked, asked
    assert all(x != y for x, y in itertools.pairwise(asked)), asked
    assert len(set(asked)) >= 4, asked


def test_the_default_robot_carries_the_thesis_numbers() -> None:
    """9.2.5 gives navigation_emotional the reward (0, 0.05, -0.01); 8.3 the step +0.33 / -0.05.
    Scenario B's alternation holds with them (tests/scenarios; docs/motivator.md says what else it needs)."""
    settings = load_config(packaged_config("cyborg.yaml")).model.motivator
    [wander] = [e for e in settings.events if e.event == "navigation_emotional"]
    assert (wander.state, wander.reward_pleasure, wander.reward_arousal, wander.reward_dominance) == (
        "idle",
        0.0,
        0.05,
        -0.01,
    )
    assert (settings.saturation_increment, settings.saturation_relief) == (0.33, 0.05)


def test_not_ready_and_handover_decisions_say_why_nothing_was_chosen() -> None:
    decision = not_ready("idle", 3.25, MotivatorSettings(min_seconds_in_state=10))
    assert (decision.status, decision.chosen, decision.candidates) == (DecisionStatus.NOT_READY, None, ())
    assert decision.reason == "3.2 s of 10 s in state 'idle': waiting before choosing (min_seconds_in_state)"
    decision = waiting_for_handover("idle", "event 'go' from cyborg_x")
    assert decision.status is DecisionStatus.HANDOVER and decision.chosen is None
    assert "'idle'" in decision.reason and "event 'go' from cyborg_x" in decision.reason


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
