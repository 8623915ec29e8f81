#!/usr/bin/env python3
"""Click-to-change latency of `shoal run` under Xvfb :91 (docs/performance.md, issue 35).
usage: tools/window-latency.py BIN FISH OUTPREFIX [extra args]
Starts `shoal run --scene porgies --fish FISH` with SHOAL_UI_TRACE=1, waits for the panel,
then clicks "pause", "play", "quick turn left" (needs `--select 0`) and "drop food" by their
traced positions, each time timing from the click to the trace line that says the panel handled
it and to the next presented frame, with screenshots OUTPREFIX-before/after-LABEL.png."""
import subprocess, sys, time, threading, re, os, queue
bin_, fish, out = sys.argv[1], sys.argv[2], sys.argv[3]
extra = sys.argv[4:]
env = dict(os.environ, DISPLAY=":91", SHOAL_UI_TRACE="1")
env.pop("WAYLAND_DISPLAY", None)
xvfb = subprocess.Popen(["Xvfb", ":91", "-screen", "0", "1600x1000x24"], stderr=subprocess.DEVNULL)
time.sleep(1.5)
args = [bin_, "run", "--scene", "porgies", "--fish", fish] + extra
p = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1)
q = queue.Queue()
log = open(out + ".log", "w")
t0 = time.time()
def reader():
    for line in p.stdout:
        now = time.time()
        log.write(f"{now-t0:9.3f} {line}"); log.flush()
        q.put((now, line.rstrip("\n")))
    q.put((time.time(), None))
threading.Thread(target=reader, daemon=True).start()
buttons = {}
frames = []
def wait_for(pred, limit):
    end = time.time() + limit
    while time.time() < end:
        try:
            now, line = q.get(timeout=0.5)
        except queue.Empty:
            continue
        if line is None:
            raise SystemExit("window exited")
        m = re.match(r'ui: button "(.*)" at (\d+),(\d+)', line)
        if m:
            buttons[m.group(1)] = (int(m.group(2)), int(m.group(3)))
        m = re.match(r'ui: frame (\d+)', line)
        if m:
            frames.append((now, int(m.group(1))))
        if pred(line):
            return now, line
    raise SystemExit(f"timed out; last frames {frames[-3:]}")
def shot(name):
    subprocess.run(["import", "-window", "root", f"{out}-{name}.png"], env=env)
try:
    wait_for(lambda l: l.startswith('ui: button "pause"'), 900)
    # let a few frames pass so the window is in its steady state
    n0 = len(frames)
    wait_for(lambda l: False if len(frames) < n0 + 3 else True, 900)
    ft = [b[0]-a[0] for a, b in zip(frames[-3:], frames[-2:])]
    print(f"steady frame times (s): {[round(x,3) for x in ft]}", flush=True)
    results = []
    clicks = [("pause", 'ui: button "play"'), ("play", None), ("quick turn left", "console: fish #0: quick turn left requested"), ("drop food", "console: food #")]
    for (label, expect) in clicks:
        shot(f"before-{label}")
        # Read what the window printed meanwhile: the button's latest position.
        try:
            wait_for(lambda l: q.empty(), 0.5)
        except SystemExit:
            pass
        if label not in buttons:
            print(f"no button {label!r}", flush=True); continue
        x, y = buttons[label]
        subprocess.run(["xdotool", "mousemove", str(x), str(y), "click", "1"], env=env)
        tc = time.time()
        fc = sum(1 for (t, _) in frames if t > tc)
        if expect is None:
            # no trace line says it (the label's line was printed before): wait 2 frames
            n1 = len(frames)
            wait_for(lambda l: len(frames) >= n1 + 2, 900)
            continue
        if label not in buttons:
            print(f"no button {label!r}", flush=True); continue
        th, _ = wait_for(lambda l: l.startswith(expect), 900)
        fh = sum(1 for (t, _) in frames if t > tc)
        tp, _ = wait_for(lambda l: l.startswith('ui: frame'), 900)
        shot(f"after-{label}")
        r = f"{label}: handled after {th-tc:.3f} s ({fh-fc} frames presented meanwhile), shown after {tp-tc:.3f} s"
        print(r, flush=True)
        results.append(r)
finally:
    p.kill(); xvfb.kill()
