"""The dashboard's state machine at 17 and at 1,000 states (issue 16), in headless Chromium against
`cyborg sim`: superstates collapse and expand, a large machine opens collapsed around the active
state, the search box finds a state or an event, the active state and the last transition stay
marked inside a collapsed superstate, and "nothing chosen" decisions leave the log to what a
person reads. Screenshots go to /tmp/cyborg-dashboard-big-*.png."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml
from playwright.sync_api import Browser, Page, expect

from cyborg.testing.machines import structured
from tests.dashboard.test_dashboard_browser import (  # the dashboard tests' robot, browser and page helpers
    SHOTS,
    SMALL,
    Sim,
    box_of,
    browser,  # noqa: F401  (a fixture)
    go_idle,
    inside,
    open_page,
    sim,  # noqa: F401  (a fixture)
)

pytestmark = pytest.mark.browser

THOUSAND = 1000


@pytest.fixture(scope="module")
def big_sim(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A robot running a generated machine of 1,000 states (superstates of 5-20, in areas)."""
    folder = tmp_path_factory.mktemp("big-machine")
    config = folder / "machine.yaml"
    config.write_text(yaml.safe_dump(structured(THOUSAND, seed=7), sort_keys=False))
    robot = Sim(folder / "data", config=config)
    try:
        yield robot.url
    finally:
        robot.stop()


def classes(page: Page, element_id: str) -> list[str]:
    found: list[str] = page.evaluate("id => [...(document.getElementById(id)?.classList || [])]", element_id)
    return found


def shown(page: Page, element_id: str) -> bool:
    visible: bool = page.evaluate(
        "id => { const n = document.getElementById(id); return !!n && n.getBoundingClientRect().width > 0; }",
        element_id,
    )
    return visible


def state_name_heights(page: Page) -> dict[str, float]:
    """The rendered height (px) of each state's name in the graph, as drawn now."""
    heights: dict[str, float] = page.evaluate(
        """() => Object.fromEntries([...document.querySelectorAll('#graph g.node[id^="state:"]')].map(
             n => [n.id.slice(6), n.querySelector('text').getBoundingClientRect().height]))"""
    )
    return heights


@pytest.mark.parametrize("size", [SMALL, (1400, 900)], ids=["1280x800", "1400x900"])
def test_seventeen_states_are_readable_at_first_view(
    browser: Browser,  # noqa: F811
    sim: str,  # noqa: F811
    size: tuple[int, int],
) -> None:
    """The shipped machine opens whole, fitted to the panel, its state names at least 10 px high
    (5 px when the drawing was 5.4 times as wide as high) and its event labels about 6 px (1280x800) and 8 px (1400x900), 4 px before."""
    errors: list[str] = []
    page = open_page(browser, sim + "/", errors, size=size)
    try:
        expect(page.locator("#graph svg")).to_be_visible()
        expect(page.locator("#conn")).to_have_attribute("data-state", "open")
        graph = box_of(page, "#graph")
        heights = state_name_heights(page)
        assert len(heights) == 11, sorted(heights)
        small = {name: round(h, 1) for name, h in heights.items() if h < 10}
        assert not small, f"state names under 10 px at {size[0]}x{size[1]}: {small}"
        for name in heights:  # the whole machine is in view
            assert inside(box_of(page, f'[id="state:{name}"]'), graph), f"{name} is outside the panel"
        events: list[float] = page.evaluate(
            "() => [...document.querySelectorAll('#graph g.edge text')].map(t => t.getBoundingClientRect().height)"
        )
        assert events and min(events) >= 5.5, f"event labels {min(events):.1f} px high (4 px before)"
        page.screenshot(path=str(SHOTS / f"cyborg-dashboard-big-17-first-{size[0]}x{size[1]}.png"))
    finally:
        page.context.close()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def test_seventeen_states_collapse_expand_and_search(browser: Browser, sim: str) -> None:  # noqa: F811
    errors: list[str] = []
    page = open_page(browser, sim + "/", errors, size=SMALL)
    try:
        expect(page.locator("#graph svg")).to_be_visible()
        go_idle(page, sim)
        assert not page.evaluate("() => window.cyborgDashboard.collapsed.size"), "17 states open expanded"
        assert shown(page, "state:joke")

        # Collapse "questions" with a click on its title: its states go, one card stands in its place.
        page.locator('[id="super:questions"] > text').click()
        expect(page.locator('[id="super:questions"]')).to_have_class("cluster collapsed")
        assert not shown(page, "state:joke") and not shown(page, "state:weather")
        card = page.locator('[id="super:questions"] .card')
        expect(card).to_contain_text("questions")
        expect(card.locator("text.detail")).to_have_text("5 states")

        # Into a question while collapsed: the card is marked active and names the state; the
        # arrow of the transition taken is marked as the last one.
        page.locator('#event-buttons button[data-event="conversation_interest"]').click()
        expect(page.locator("#top-state")).to_have_text("conversation")
        page.locator('#event-buttons button[data-event="joke_tell"]').click()
        expect(page.locator("#top-state")).to_have_text("joke")
        expect(page.locator('[id="super:questions"]')).to_have_class(
            "cluster collapsed active-parent active-inside"
        )
        expect(card.locator("text.detail")).to_have_text("5 states · active: joke")
        assert "last" in classes(page, "edge:conversation:follower_follow"), (
            "the arrow conversation -> questions (joke_tell among its events) is the last transition"
        )
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-big-17-collapsed.png"))

        # Expand with a click on the card: the states are back, joke marked active.
        card.click()
        expect(page.locator('[id="state:joke"]')).to_have_class("node active")
        assert shown(page, "state:joke")

        # Search: a state, then an event; each comes into view, readable, marked as found.
        page.locator('[id="super:navigation"] > text').click()
        assert not shown(page, "state:navigation_moving")
        page.fill("#graph-search", "navigation_moving")
        page.press("#graph-search", "Enter")
        expect(page.locator('[id="state:navigation_moving"]')).to_have_class("node found")
        graph = box_of(page, "#graph")
        assert inside(box_of(page, '[id="state:navigation_moving"]'), graph)
        assert box_of(page, '[id="state:navigation_moving"] text')["height"] >= 12
        page.fill("#graph-search", "music_play")
        page.press("#graph-search", "Enter")
        expect(page.locator('[id="edge:idle:music_play"]')).to_have_class("edge found")
        assert inside(box_of(page, '[id="edge:idle:music_play"] text'), graph)
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-big-17-search.png"))
        go_idle(page, sim)
    finally:
        page.context.close()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def test_a_thousand_states_open_collapsed_around_the_active_state(browser: Browser, big_sim: str) -> None:  # noqa: F811
    errors: list[str] = []
    page = open_page(browser, big_sim + "/", errors, size=SMALL)
    try:
        expect(page.locator("#conn")).to_have_attribute("data-state", "open")
        expect(page.locator("#graph-caption")).to_contain_text(f"{THOUSAND} states")
        assert page.request.get(big_sim + "/api/graph.svg").headers["x-graph-layout"] == "graphviz"
        page.wait_for_function("() => window.cyborgDashboard.collapsed.size > 0")
        state = page.locator("#top-state").inner_text()
        machine = {s["name"]: s for s in page.request.get(big_sim + "/api/machine").json()["states"]}
        around, parent = set(), machine[state]["parent"]
        while parent:
            around.add(parent)
            parent = machine[parent]["parent"]
        collapsed = set(page.evaluate("() => [...window.cyborgDashboard.collapsed]"))
        supers = {name for name, s in machine.items() if not s["leaf"]}
        assert collapsed == supers - around, "collapsed but for the superstates around the active state"
        assert shown(page, f"state:{state}"), "the active state is drawn"
        expect(page.locator(f'[id="state:{state}"]')).to_have_class("node active")
        visible = page.evaluate(
            "() => [...document.querySelectorAll('#graph g.node[id^=\"state:\"]')].filter(n => !n.closest('.folded') && !n.classList.contains('folded')).length"
        )
        assert visible < 60, f"{visible} states drawn at once: the machine did not open collapsed"
        assert inside(box_of(page, f'[id="state:{state}"]'), box_of(page, "#graph"))
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-big-1000-open.png"))

        # Into a state of another area: still marked, on the collapsed area's card.
        page.request.post(big_sim + "/api/event", data={"name": "start_area3"})
        page.wait_for_function(
            "() => document.querySelector('[id=\"super:area3\"]')?.classList.contains('active-inside')"
        )
        now = page.locator("#top-state").inner_text()
        expect(page.locator('[id="super:area3"] .card text.detail')).to_contain_text(f"active: {now}")

        # Search finds a state deep in a collapsed area and opens the way to it.
        page.fill("#graph-search", "g40_s2")
        page.press("#graph-search", "Enter")
        expect(page.locator('[id="state:g40_s2"]')).to_have_class("node found")
        assert shown(page, "state:g40_s2")
        assert inside(box_of(page, '[id="state:g40_s2"]'), box_of(page, "#graph"))
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-big-1000-search.png"))

        # The log: a placeholder state lasts 5 s, the motivator decides every 2 s and chooses
        # nothing here; those decisions are counted, not listed, so state changes fill the view.
        for _ in range(12):
            before = page.locator("#top-state").inner_text()
            page.request.post(big_sim + "/api/event", data={"name": "next"})
            expect(page.locator("#top-state")).not_to_have_text(before)
        page.wait_for_timeout(2500)
        counted = int(page.locator("#log-count").get_attribute("data-idle") or 0)
        assert counted > 0, "the motivator's nothing-chosen decisions are counted"
        expect(page.locator("#log-count")).to_contain_text("nothing chosen (hidden)")
        in_view = page.evaluate(
            """() => { const box = document.getElementById('log').getBoundingClientRect();
                 return [...document.querySelectorAll('#log li')].filter(r => { const b = r.getBoundingClientRect();
                   return b.top >= box.top - 1 && b.bottom <= box.bottom + 1; }).map(r => r.dataset.type); }"""
        )
        assert in_view.count("state") >= 10, f"rows in view: {in_view}"
        page.locator('.log-filters input[data-type="nothing"]').check()
        expect(page.locator('#log li[data-type="motivator"][data-chosen="no"]').first).to_be_visible()
        page.locator('.log-filters input[data-type="nothing"]').uncheck()
        page.screenshot(path=str(SHOTS / "cyborg-dashboard-big-1000-log.png"))
    finally:
        page.context.close()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def test_the_big_machine_file_is_valid(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from cyborg.cli import cli

    path = tmp_path / "m.yaml"
    path.write_text(yaml.safe_dump(structured(THOUSAND, seed=7), sort_keys=False))
    result = CliRunner().invoke(cli, ["graph", str(path), "-o", str(tmp_path / "m.svg")])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "m.svg").read_text().count('class="node"') >= THOUSAND
