"""Ground monitor fed over zenoh: the fleet's picture (state.py), the zenoh feed (feed.py), a local web page
pushed over server-sent events (web.py, static/index.html), a terminal view (tui.py), a Python router
stand-in (router.py) and a simulated vehicle for tests and demos (sim.py). See docs/monitor.md."""
