"""xssbrowser.py URL: open the dashboard in Chromium; send the markup event and a markup say; any dialog, injected img or script?"""
import json, sys, time, urllib.request
from playwright.sync_api import sync_playwright
URL = sys.argv[1]; J = {"Content-Type": "application/json"}
def post(path, body):
    with urllib.request.urlopen(urllib.request.Request(URL + path, data=json.dumps(body).encode(), headers=J), timeout=30) as r: return json.load(r)
with sync_playwright() as p:
    b = p.chromium.launch(executable_path="/usr/bin/chromium", args=["--no-sandbox", "--disable-gpu"])
    page = b.new_page(viewport={"width": 1400, "height": 900}); dialogs = []; errors = []
    page.on("dialog", lambda d: (dialogs.append(d.message), d.dismiss()))
    page.on("console", lambda m: m.type == "error" and errors.append(m.text))
    page.goto(URL + "/"); page.wait_for_selector("#graph svg", timeout=60000)
    print("event:", post("/api/event", {"name": '"><img src=x onerror=alert(1)>'}))
    print("say:", post("/api/say", {"text": "<img src=x onerror=alert(4)><script>alert(5)</script> where is the cafeteria"}))
    time.sleep(6)
    state = page.evaluate("() => document.body.innerText.includes('<img src=x onerror=alert(2)>')")
    imgs = page.evaluate("() => [...document.querySelectorAll('img')].map(i => i.getAttribute('src'))")
    scripts = page.evaluate("() => [...document.querySelectorAll('script')].map(s => s.src || s.textContent.slice(0, 40))")
    heard = page.evaluate("() => [...document.querySelectorAll('#log li')].map(l => l.textContent).filter(t => t.includes('img')).slice(0, 3)")
    page.screenshot(path="/tmp/cyborg-xss.png")
    print(f"dialogs {dialogs}; img elements {imgs}; scripts {scripts}; state name shown as text: {state}; log lines with the markup as text: {heard}; console errors {errors}")
    b.close()
