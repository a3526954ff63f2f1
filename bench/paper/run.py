#!/usr/bin/python3
"""Reproduces the paper's Table and Figure (Section 6) with real processes.

One excite-server per parallel job (--servers, default --jobs; free loopback ports,
temporary data directories): a server serialises its Ipopt solves, so one server per
job lets two planning trials use both cores. Every trial is one excite-sim process
talking to the least busy server over gRPC, --jobs of them at a time. Seeds are the trial index (+ --seed_offset); the evaluation set is the
system config's, the same for every trial and strategy.

  bench/paper/run.py                   full mode (trial counts: benchmark.json)
  bench/paper/run.py --quick           small sample budgets, 1-2 trials (< 10 min)
  bench/paper/run.py --ci              pendulum + one MuJoCo system, tiny budgets,
                                       then checks the outputs (exit 1 on a problem)
  bench/paper/run.py --report_only DIR re-aggregate an existing results directory
  bench/paper/run.py --report_only DIR1 DIR2 results.csv ... --out DIR
                                       combine runs (a later source's trial wins)

Systems without a config and strategies excite-sim does not know are reported and
skipped. Outputs (default results/paper/<timestamp>/): results.csv, trials.csv,
table.md, summary.json, rmse_<system>.png, rmse_all.png, coverage.png, server*.log and
trials/<system>/<strategy>/trial<k>.{json,log}. Standard library + matplotlib only;
run it with Debian's /usr/bin/python3.
"""

import argparse
import datetime
import json
import os
import platform
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)

import aggregate  # noqa: E402
import check  # noqa: E402

DEFAULT_CONFIG = os.path.join(HERE, "benchmark.json")
DEFAULT_SERVER = os.path.join(REPO, "build", "release", "server", "excite-server")
DEFAULT_SIM = os.path.join(REPO, "build", "release", "sim", "excite-sim")
PROGRESS_RE = re.compile(rb"samples (\d+)")


def log(msg=""):
    Progress.clear()
    print(msg, flush=True)


def fmt_duration(seconds):
    if seconds is None:
        return "?"
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{(seconds % 3600) // 60:02d}m"


class Progress:
    """A status line: rewritten in place on a terminal, printed every 30 s
    otherwise (ctest, CI logs)."""
    tty = sys.stdout.isatty()
    shown = False
    last_print = 0.0

    @classmethod
    def clear(cls):
        if cls.tty and cls.shown:
            sys.stdout.write("\r\033[K")
            cls.shown = False

    @classmethod
    def show(cls, text):
        if cls.tty:
            width = shutil.get_terminal_size((120, 20)).columns - 1
            sys.stdout.write("\r\033[K" + text[:width])
            sys.stdout.flush()
            cls.shown = True
        elif time.monotonic() - cls.last_print >= 30:
            print(text, flush=True)
            cls.last_print = time.monotonic()


# --------------------------------------------------------------------------- plan


class Trial:
    def __init__(self, system, strategy, index, seed, samples, config, out_dir):
        self.system = system
        self.strategy = strategy
        self.index = index
        self.seed = seed
        self.samples = samples  # None: the config's
        self.config = config
        d = os.path.join(out_dir, "trials", system, strategy)
        self.summary_path = os.path.join(d, f"trial{index}.json")
        self.log_path = os.path.join(d, f"trial{index}.log")
        self.status = "queued"  # queued, running, ok, failed, skipped
        self.error = ""
        self.wall = None
        self.proc = None
        self.start = None
        self.result = None

    @property
    def pair(self):
        return (self.system, self.strategy)

    def name(self):
        return f"{self.system}/{self.strategy}#{self.index}"


def load_config(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def trial_count(spec, strategy):
    if isinstance(spec, dict):
        return int(spec.get(strategy, spec.get("default", 1)))
    return int(spec)


def config_samples(config_path):
    """The `samples:` of a SimConfig textproto (top level), or None."""
    try:
        with open(config_path, encoding="utf-8") as f:
            for line in f:
                m = re.match(r"^samples:\s*(\d+)", line)
                if m:
                    return int(m.group(1))
    except OSError:
        pass
    return None


def split_list(values):
    out = []
    for v in values or []:
        out += [x for x in re.split(r"[,\s]+", v) if x]
    return out


def preflight(sim_bin, pairs, config_paths):
    """Which (system, strategy) pairs excite-sim accepts: it is run against an
    address nobody listens on with connect_timeout_s=0, so it parses the config and
    the strategy, validates, builds the plant, then fails to connect. Any other
    failure is the reason to skip the pair. Returns {pair: '' or reason}."""
    procs = {}
    for system, strategy in pairs:
        cmd = [sim_bin, "--server=127.0.0.1:1", "--connect_timeout_s=0",
               f"--config={config_paths[system]}", f"--strategy={strategy}"]
        procs[(system, strategy)] = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, cwd=REPO)
    reasons = {}
    for pair, p in procs.items():
        out, _ = p.communicate(timeout=60)
        text = out.decode("utf-8", "replace").strip()
        if "cannot reach excite-server" in text:
            reasons[pair] = ""
        else:
            lines = [l for l in text.splitlines() if l.strip()]
            reasons[pair] = lines[-1] if lines else f"excite-sim exit code {p.returncode}"
    return reasons


def condense_skipped(skipped):
    """[(what, reason)]: one line per strategy when the same reason (a strategy
    excite-sim does not know) holds for several systems."""
    by_key = {}
    for system, strategy, reason in skipped:
        by_key.setdefault((strategy, reason), []).append(system)
    out = []
    for (strategy, reason), systems in by_key.items():
        if strategy == "*":
            out += [(s, reason) for s in systems]
        elif len(systems) == 1:
            out.append((f"{systems[0]}/{strategy}", reason))
        else:
            out.append((f"{strategy} on {', '.join(systems)}", reason))
    return out


def select_systems(cfg, args, mode):
    names = list(cfg["systems"])
    if args.systems:
        chosen = split_list(args.systems)
        unknown = [s for s in chosen if s not in cfg["systems"]]
        if unknown:
            sys.exit(f"run.py: unknown system(s) {unknown}; known: {names}")
        return chosen
    if mode == "ci":
        chosen = list(cfg["ci"]["systems"])
        for s in cfg["ci"].get("mujoco_one_of", []):
            path = os.path.join(REPO, cfg["systems"][s]["config"])
            if os.path.isfile(path):
                chosen.append(s)
                break
        return chosen
    # Held-out plants run only when named: nothing is tuned on them.
    return [s for s in names if not cfg["systems"][s].get("held_out")]


def make_plan(cfg, args, mode, out_dir):
    """Returns (trials, skipped, planned, samples_of) where skipped is
    [(system, strategy or '*', reason)]."""
    systems = select_systems(cfg, args, mode)
    strategies = split_list(args.strategies) or list(cfg["strategies"])
    skipped = []
    config_paths = {}
    for system in systems:
        path = os.path.join(REPO, cfg["systems"][system]["config"])
        if os.path.isfile(path):
            config_paths[system] = path
        else:
            skipped.append((system, "*", f"no config {cfg['systems'][system]['config']}"
                                          " (system not implemented yet)"))
    pairs = [(s, st) for s in systems if s in config_paths for st in strategies]
    reasons = preflight(args.sim_bin, pairs, config_paths) if pairs else {}
    available = []
    for pair in pairs:
        if reasons[pair]:
            skipped.append((pair[0], pair[1], reasons[pair]))
        else:
            available.append(pair)
    trials_by_pair = {}
    samples_of = {}
    planned = {}
    for system, strategy in available:
        block = cfg["systems"][system][mode]
        n = args.trials if args.trials else trial_count(block["trials"], strategy)
        samples = args.samples or block.get("samples")
        samples_of[system] = samples or config_samples(config_paths[system])
        planned[(system, strategy)] = n
        trials_by_pair[(system, strategy)] = [
            Trial(system, strategy, k, args.seed_offset + k, samples,
                  config_paths[system], out_dir) for k in range(n)]
    # Trial-major order: trial 0 of every pair first (failures show early, and an
    # interrupted run has every pair), then trial 1 of every pair, and so on.
    trials = []
    rounds = max((len(v) for v in trials_by_pair.values()), default=0)
    for k in range(rounds):
        for pair, ts in trials_by_pair.items():
            if k < len(ts):
                trials.append(ts[k])
    return trials, skipped, planned, samples_of, systems, strategies


# ------------------------------------------------------------------------- server


class Server:
    def __init__(self, binary, out_dir, keep_data, index=0):
        self.data_dir = tempfile.mkdtemp(prefix="excite-bench-")
        self.keep_data = keep_data
        self.running = 0  # trials currently talking to this server
        suffix = f"-{index}" if index else ""
        self.log_path = os.path.join(out_dir, f"server{suffix}.log")
        self.stdout_path = os.path.join(out_dir, f"server{suffix}.stdout")
        self.stdout = open(self.stdout_path, "wb")
        self.stderr = open(self.log_path, "wb")
        self.proc = subprocess.Popen(
            [binary, "--listen=127.0.0.1:0", f"--data_dir={self.data_dir}"],
            stdout=self.stdout, stderr=self.stderr, cwd=REPO, start_new_session=True)
        self.address = None

    def wait_ready(self, timeout=30.0):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with open(self.stdout_path, "rb") as f:
                m = re.search(rb"^excite-server listening on (\S+)$", f.read(), re.M)
            if m:
                self.address = m.group(1).decode()
                return self.address
            if self.proc.poll() is not None:
                raise RuntimeError(f"excite-server exited with {self.proc.returncode}; "
                                   f"see {self.log_path}")
            time.sleep(0.05)
        raise RuntimeError(f"excite-server not ready within {timeout:.0f} s")

    def alive(self):
        return self.proc.poll() is None

    def stop(self):
        code = self.proc.poll()
        if code is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                code = self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                code = self.proc.wait()
        self.stdout.close()
        self.stderr.close()
        if not self.keep_data:
            shutil.rmtree(self.data_dir, ignore_errors=True)
        return code


# ------------------------------------------------------------------------- trials


def start_trial(t, sim_bin, address, session_override=""):
    os.makedirs(os.path.dirname(t.log_path), exist_ok=True)
    for p in (t.summary_path,):
        if os.path.exists(p):
            os.remove(p)
    cmd = [sim_bin, f"--server={address}", f"--config={t.config}",
           f"--strategy={t.strategy}", f"--seed={t.seed}", f"--summary={t.summary_path}"]
    if t.samples:
        cmd.append(f"--samples={t.samples}")
    if session_override:
        cmd.append(f"--session_override={session_override}")
    logf = open(t.log_path, "wb")
    logf.write(("$ " + " ".join(cmd) + "\n").encode())
    logf.flush()
    t.proc = subprocess.Popen(cmd, stdout=logf, stderr=subprocess.STDOUT, cwd=REPO,
                              start_new_session=True)
    t.logf = logf
    t.start = time.monotonic()
    t.status = "running"


def trial_progress(t):
    """Samples reached so far, from the last 'samples N' in the trial's log."""
    try:
        with open(t.log_path, "rb") as f:
            f.seek(0, os.SEEK_END)
            size = f.tell()
            f.seek(max(0, size - 400))
            found = PROGRESS_RE.findall(f.read())
        return int(found[-1]) if found else 0
    except OSError:
        return 0


def last_error(path):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            lines = [l.strip() for l in f if l.strip()]
    except OSError:
        return "no log"
    # excite-sim's failure line: "excite-sim: <message> (<STATUS_CODE>)".
    errors = [l for l in lines if re.match(r"^excite-sim: .*\([A-Z_]+\)$", l)]
    return (errors or lines or ["empty log"])[-1]


def finish_trial(t):
    code = t.proc.returncode
    t.wall = time.monotonic() - t.start
    t.logf.close()
    if code == 0:
        try:
            with open(t.summary_path, encoding="utf-8") as f:
                s = json.load(f)
            s["system_reported"] = s.get("system")
            s["system"], s["strategy"] = t.system, t.strategy
            s["trial"], s["seed"] = t.index, t.seed
            t.result = s
            t.status = "ok"
            return
        except (OSError, ValueError) as e:
            t.error = f"exit 0 but no summary: {e}"
    elif code < 0:
        t.error = f"killed by signal {-code}"
    else:
        t.error = last_error(t.log_path)
    t.status = "failed"


class Estimator:
    """Expected wall time of a trial: the mean of its pair's finished trials; else
    extrapolated from a running trial of its pair (an underestimate: later samples
    cost more, the GP grows); else seconds per sample of the same strategy on other
    systems, of its system, of all finished trials; else the same from the running
    trials' progress."""

    def __init__(self):
        self.done = []  # (system, strategy, samples, wall)
        self.partial = []  # the same for running trials, refreshed by the caller

    def add(self, t, samples):
        self.done.append((t.system, t.strategy, samples or 1, t.wall))

    def estimate(self, t, samples):
        same = [w for s, st, _, w in self.done if (s, st) == t.pair]
        if same:
            return sum(same) / len(same)
        picks = (lambda s, st: (s, st) == t.pair, lambda s, st: st == t.strategy,
                 lambda s, st: s == t.system, lambda s, st: True)
        for rows_all, pick_list in ((self.partial, picks[:1]), (self.done, picks[1:]),
                                    (self.partial, picks[1:])):
            for pick in pick_list:
                rows = [(n, w) for s, st, n, w in rows_all if pick(s, st) and n > 0]
                if rows:
                    per_sample = sum(w for _, w in rows) / sum(n for n, _ in rows)
                    return per_sample * (samples or 1)
        return None


def run_trials(trials, args, servers, samples_of):
    jobs = max(1, args.jobs)
    queue = list(trials)
    running = []
    broken = {}  # pair -> reason
    succeeded_pairs = set()
    est = Estimator()
    total = len(trials)
    done = failed = 0
    t0 = time.monotonic()
    timeout = args.trial_timeout

    def eta():
        now = time.monotonic()
        est.partial = [(r.system, r.strategy, trial_progress(r), now - r.start)
                       for r in running]
        rem = 0.0
        for q in queue:
            e = est.estimate(q, samples_of.get(q.system))
            if e is None:
                return None
            rem += e
        for r in running:
            e = est.estimate(r, samples_of.get(r.system))
            elapsed = now - r.start
            n, big_n = trial_progress(r), samples_of.get(r.system) or 0
            if e is None:
                if n <= 0 or not big_n:
                    return None
                e = elapsed * big_n / n
            rem += max(e - elapsed, 0.0)
        return rem / jobs

    def status_line():
        now = time.monotonic()
        parts = []
        for r in running:
            n = trial_progress(r)
            parts.append(f"{r.name()} {n}/{samples_of.get(r.system) or '?'} "
                         f"{fmt_duration(now - r.start)}")
        e = eta()
        return (f"[{done}/{total} done, {failed} failed] running: "
                + ", ".join(parts) + f" | elapsed {fmt_duration(now - t0)}, "
                f"left ~{fmt_duration(e) if e is not None else '?'}")

    try:
        while queue or running:
            for server in servers:
                if not server.alive():
                    raise RuntimeError(f"excite-server exited with "
                                       f"{server.proc.returncode}; see {server.log_path}")
            while len(running) < jobs and queue:
                t = queue.pop(0)
                if t.pair in broken:
                    t.status, t.error = "skipped", broken[t.pair]
                    continue
                t.server = min(servers, key=lambda s: s.running)
                t.server.running += 1
                start_trial(t, args.sim_bin, t.server.address, args.session_override)
                running.append(t)
            for r in list(running):
                if r.proc.poll() is None:
                    if timeout and time.monotonic() - r.start > timeout:
                        os.kill(r.proc.pid, signal.SIGKILL)
                        r.proc.wait()
                        finish_trial(r)
                        r.error = f"timeout after {timeout:.0f} s"
                    else:
                        continue
                else:
                    finish_trial(r)
                running.remove(r)
                r.server.running -= 1
                if r.status == "ok":
                    done += 1
                    succeeded_pairs.add(r.pair)
                    est.add(r, r.result.get("samples"))
                    s = r.result
                    cov = s.get("coverage_marginal")
                    e = eta()
                    log(f"[{done + failed}/{total}] {r.name()} seed {r.seed}: "
                        f"{s.get('samples')} samples, rmse {s.get('final_rmse'):.4g}, "
                        f"coverage {100 * cov if cov is not None else float('nan'):.1f}% "
                        f"({r.wall:.1f} s) | elapsed {fmt_duration(time.monotonic() - t0)}"
                        f", left ~{fmt_duration(e) if e is not None else '?'}")
                else:
                    failed += 1
                    log(f"[{done + failed}/{total}] {r.name()} FAILED: {r.error} "
                        f"(log {os.path.relpath(r.log_path)})")
                    if r.pair not in succeeded_pairs and r.pair not in broken:
                        broken[r.pair] = f"skipped: first trial failed: {r.error}"
                        n = sum(1 for q in queue if q.pair == r.pair)
                        if n:
                            log(f"    {r.system}/{r.strategy}: skipping its {n} other "
                                "trial(s)")
            if running:
                Progress.show(status_line())
            time.sleep(0.25)
    except KeyboardInterrupt:
        log("interrupted: stopping the running trials")
        for r in running:
            try:
                os.kill(r.proc.pid, signal.SIGTERM)
                r.proc.wait(timeout=10)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                os.kill(r.proc.pid, signal.SIGKILL)
                r.proc.wait()
            finish_trial(r)
            r.status, r.error = "failed", "interrupted"
        for q in queue:
            q.status, q.error = "skipped", "interrupted"
        Progress.clear()
        return True
    Progress.clear()
    return False


# ------------------------------------------------------------------------ reports


def machine_description():
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    os_name = platform.platform()
    try:
        with open("/etc/os-release", encoding="utf-8") as f:
            for line in f:
                if line.startswith("PRETTY_NAME="):
                    os_name = line.split("=", 1)[1].strip().strip('"')
    except OSError:
        pass
    return f"{os.cpu_count()} x {cpu}, {os_name}"


def git_commit():
    try:
        out = subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"],
                             capture_output=True, text=True, timeout=10)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def write_reports(out_dir, cfg, meta, trial_records, results):
    """results.csv, trials.csv, table.md, summary.json and the plots."""
    systems = [s for s in meta["systems"]]
    strategies = meta["strategies"]
    sys_labels = {s: cfg["systems"].get(s, {}).get("label", s) for s in systems}
    st_labels = cfg.get("strategy_labels", {})
    planned = {tuple(k.split("/")): v for k, v in meta["planned"].items()}

    aggregate.write_csv(os.path.join(out_dir, "results.csv"), results)
    with open(os.path.join(out_dir, "trials.csv"), "w", encoding="utf-8") as f:
        f.write("system,strategy,trial,seed,status,samples,final_rmse,"
                "coverage_marginal,coverage_joint,plan_ms_p50,wall_s,final_nlpd,"
                "final_inside_95,rollout_rmse_10,rollout_rmse_30,midway_samples,"
                "midway_rmse,midway_rollout_rmse_30,planned_by,error\n")
        for r in trial_records:
            s = r.get("result") or {}
            vals = [r["system"], r["strategy"], r["trial"], r["seed"], r["status"],
                    s.get("samples", ""), s.get("final_rmse", ""),
                    s.get("coverage_marginal", ""), s.get("coverage_joint", ""),
                    s.get("plan_ms_p50", ""), s.get("wall_s", ""),
                    s.get("final_nlpd", ""), s.get("final_inside_95", ""),
                    s.get("rollout_rmse_10", ""), s.get("rollout_rmse_30", ""),
                    s.get("midway_samples", ""), s.get("midway_rmse", ""),
                    s.get("midway_rollout_rmse_30", ""),
                    " ".join(f"{k}:{v}" for k, v in (s.get("planned_by") or {}).items())]
            vals = ["" if v is None else str(v) for v in vals]
            err = (r.get("error") or "").replace('"', "'")
            f.write(",".join(vals) + f',"{err}"\n')

    stats = aggregate.final_stats(results)
    history = aggregate.history_stats(results)
    shown_systems = [s for s in systems if any((s, st) in planned for st in strategies)]
    shown_strats = [st for st in strategies if any((s, st) in planned for s in systems)]
    if not shown_systems or not shown_strats:
        shown_systems, shown_strats = systems, strategies

    samples = ", ".join(f"{sys_labels[s]} {meta['samples'].get(s)}"
                        for s in shown_systems)
    mode_text = {"full": "full mode", "quick": "QUICK mode (small sample budgets, "
                 "not the paper's protocol)", "ci": "CI mode (tiny budgets; a smoke "
                 "test, the numbers mean nothing)", "csv": "re-plotted from a "
                 "results.csv"}.get(meta["mode"], meta["mode"] + " modes")
    lines = [
        f"# Paper benchmark: final RMSE and coverage ({meta['mode']})",
        "",
        f"- Mode: {mode_text}{meta.get('overrides', '')}; samples per trial: "
        f"{samples}.",
        f"- Run: {meta['started']}, {fmt_duration(meta.get('wall_s'))} wall"
        f"{' (sum over the runs)' if len(meta.get('sources', [])) > 1 else ''}, "
        f"--jobs {meta['jobs']}, {meta.get('servers', 1)} server(s), commit {meta['commit']}.",
        f"- Machine: {meta['machine']}.",
        f"- Command: `{meta['command']}`",
    ] + [
        f"- Source: `{src['path']}` ({src.get('mode')}, {src.get('started')}, commit "
        f"{src.get('commit')}" + (f": `{src['command']}`)" if src.get("command")
                                  else ")")
        for src in meta.get("sources", [])
    ] + [
        "- Cells: mean ± sample std over the successful trials (seeds = trial index); "
        "best per column in **bold** (lowest RMSE, highest coverage). RMSE in state "
        "units over the config's evaluation set; coverage marginal = mean over state "
        "dimensions of the fraction of bins visited; joint = fraction of "
        "joint_bins^dx cells (n/a for dx > 4); see sim/README.md.",
        "",
        aggregate.markdown_table(stats, shown_systems, shown_strats, sys_labels,
                                 st_labels, history=history),
        "Trials (succeeded/planned):",
        "",
        aggregate.trial_count_table(stats, planned, shown_systems, shown_strats,
                                    sys_labels, st_labels),
    ]
    ok_records = [r for r in trial_records if r["status"] == "ok" and r.get("result")
                  and r.get("seed") is not None]
    if any(r["strategy"] == "rec" for r in ok_records):
        lines.append(aggregate.paired_section(ok_records, shown_systems, shown_strats,
                                              sys_labels, st_labels))
    if ok_records:
        lines.append(aggregate.calibration_table(ok_records, shown_systems,
                                                 shown_strats, sys_labels, st_labels))
    if meta["skipped"]:
        lines.append("Not run:")
        lines.append("")
        for what, reason in condense_skipped(meta["skipped"]):
            lines.append(f"- {what}: {reason}")
        lines.append("")
    failed = [r for r in trial_records if r["status"] in ("failed", "skipped")]
    if failed:
        lines.append("Failed or skipped trials:")
        lines.append("")
        for r in failed:
            lines.append(f"- {r['system']}/{r['strategy']} trial {r['trial']}: "
                         f"{r['status']}: {r.get('error', '')}")
        lines.append("")
    table_md = "\n".join(lines)
    with open(os.path.join(out_dir, "table.md"), "w", encoding="utf-8") as f:
        f.write(table_md)

    with open(os.path.join(out_dir, "summary.json"), "w", encoding="utf-8") as f:
        json.dump({
            "meta": meta,
            "final": [{"system": k[0], "strategy": k[1], **v} for k, v in stats.items()],
            "history": [{"system": k[0], "strategy": k[1],
                         "points": [{"samples": p[0], "mean": p[1], "std": p[2],
                                     "n": p[3]} for p in v]}
                        for k, v in history.items()],
        }, f, indent=1)

    pngs = []
    try:
        import plots
    except ImportError as e:
        log(f"WARNING: no plots ({e}); install python3-matplotlib and run "
            f"{sys.argv[0]} --report_only {out_dir}")
        return table_md, pngs
    subtitle = {"full": "", "quick": "quick mode", "ci": "CI mode"}.get(meta["mode"],
                                                                       "")
    for s in shown_systems:
        path = os.path.join(out_dir, f"rmse_{s}.png")
        if plots.plot_rmse_system(path, history, s, shown_strats, sys_labels[s],
                                  st_labels, subtitle):
            pngs.append(path)
    path = os.path.join(out_dir, "rmse_all.png")
    if plots.plot_rmse_all(path, history, shown_systems, shown_strats, sys_labels,
                           st_labels, subtitle):
        pngs.append(path)
    path = os.path.join(out_dir, "coverage.png")
    if plots.plot_coverage(path, stats, shown_systems, shown_strats, sys_labels,
                           st_labels, subtitle):
        pngs.append(path)
    return table_md, pngs


def trial_record(t):
    return {"system": t.system, "strategy": t.strategy, "trial": t.index,
            "seed": t.seed, "status": t.status, "error": t.error, "wall": t.wall,
            "result": t.result}


def load_report_source(path):
    """(meta, records) of one --report_only source: a results directory (its
    run.json) or a results.csv (trials rebuilt from it: histories, final RMSE,
    coverage and plan time; no wall times, seeds or failed trials)."""
    if os.path.isdir(path):
        with open(os.path.join(path, "run.json"), encoding="utf-8") as f:
            saved = json.load(f)
        return saved["meta"], saved["trials"]
    trials = aggregate.read_csv(path)
    records = [{"system": t["system"], "strategy": t["strategy"], "trial": t["trial"],
                "seed": None, "status": "ok", "error": "", "wall": None, "result": t}
               for t in trials]
    samples = {}
    for t in trials:
        samples[t["system"]] = max(samples.get(t["system"], 0), t["samples"])
    meta = {"mode": "csv", "started": "?", "command": "", "jobs": "?",
            "servers": "?", "machine": "?", "commit": "?",
            "systems": list(dict.fromkeys(t["system"] for t in trials)),
            "strategies": list(dict.fromkeys(t["strategy"] for t in trials)),
            "planned": {}, "samples": samples, "skipped": [], "wall_s": None}
    return meta, records


def _joined(values, sep=", "):
    return sep.join(dict.fromkeys(str(v) for v in values if v not in (None, "")))


def merge_sources(sources, cfg, command):
    """One (meta, records) from several --report_only sources (directories or
    results.csv files), in the order given: a later source's trial replaces an
    earlier one with the same (system, strategy, trial index), except that a
    failed or skipped trial never replaces a successful one. Systems and
    strategies come out in benchmark.json's order; planned = the trials merged."""
    by_key, metas = {}, []
    for path in sources:
        meta, records = load_report_source(path)
        metas.append((path, meta))
        for r in records:
            key = (r["system"], r["strategy"], r["trial"])
            old = by_key.get(key)
            if old is None or r["status"] == "ok" or old["status"] != "ok":
                by_key[key] = r
    records = [by_key[k] for k in sorted(by_key)]

    def in_config_order(names, known):
        names = list(dict.fromkeys(names))
        return [n for n in known if n in names] + [n for n in names if n not in known]

    systems = in_config_order([s for _, m in metas for s in m["systems"]],
                              list(cfg["systems"]))
    strategies = in_config_order([s for _, m in metas for s in m["strategies"]],
                                 list(cfg["strategies"]))
    planned = {}
    for r in records:
        k = f"{r['system']}/{r['strategy']}"
        planned[k] = planned.get(k, 0) + 1
    samples = {}
    for _, m in metas:
        samples.update(m.get("samples") or {})
    ok_pairs = {(r["system"], r["strategy"]) for r in records if r["status"] == "ok"}
    skipped = []
    for _, m in metas:
        for item in m.get("skipped") or []:
            item = list(item)
            if (item[0], item[1]) not in ok_pairs and item not in skipped:
                skipped.append(item)
    modes = sorted({m["mode"] for _, m in metas})
    started = sorted(m["started"] for _, m in metas if m.get("started") not in
                     (None, "?"))
    walls = [m.get("wall_s") for _, m in metas if m.get("wall_s") is not None]
    meta = {
        "mode": modes[0] if len(modes) == 1 else "+".join(modes),
        "started": (started[0] if len(started) == 1 else
                    f"{started[0]} to {started[-1]}" if started else "?"),
        "wall_s": sum(walls) if walls else None,
        "command": command,
        "jobs": _joined(m.get("jobs") for _, m in metas) or "?",
        "servers": _joined(m.get("servers") for _, m in metas) or "?",
        "machine": _joined((m.get("machine") for _, m in metas), "; ") or "?",
        "commit": _joined(m.get("commit") for _, m in metas) or "?",
        "systems": systems, "strategies": strategies, "planned": planned,
        "samples": samples, "skipped": skipped, "overrides": "",
        "sources": [{"path": path, "command": m.get("command", ""),
                     "started": m.get("started", "?"), "commit": m.get("commit", "?"),
                     "mode": m.get("mode")} for path, m in metas],
    }
    return meta, records


def filter_report(meta, records, systems, strategies):
    """Only the given systems and strategies (None: all) in the report."""
    if systems:
        meta["systems"] = [s for s in meta["systems"] if s in systems]
    if strategies:
        meta["strategies"] = [s for s in meta["strategies"] if s in strategies]
    keep = [r for r in records
            if r["system"] in meta["systems"] and r["strategy"] in meta["strategies"]]
    meta["planned"] = {k: v for k, v in meta["planned"].items()
                       if tuple(k.split("/")) in
                       {(r["system"], r["strategy"]) for r in keep}}
    return meta, keep


def report_only(sources, cfg, out=None, systems=None, strategies=None, argv=()):
    """Re-aggregates and re-plots. One results directory without --out: in place
    (as before). Several sources, a results.csv, or --systems/--strategies: into
    --out, which gets results.csv, trials.csv, table.md, summary.json, the plots
    and a run.json (so that --report_only OUT works on it too)."""
    combined = len(sources) > 1 or not os.path.isdir(sources[0]) or systems \
        or strategies
    if not out and combined:
        sys.exit("run.py: --report_only with several sources, a results.csv or "
                 "--systems/--strategies writes to --out DIR; give one")
    if not out:
        out_dir = sources[0]
        with open(os.path.join(out_dir, "run.json"), encoding="utf-8") as f:
            saved = json.load(f)
        meta, records = saved["meta"], saved["trials"]
    else:
        out_dir = os.path.abspath(out)
        if any(os.path.abspath(s) == out_dir for s in sources):
            sys.exit("run.py: --out must not be one of the --report_only sources")
        meta, records = merge_sources(
            sources, cfg, " ".join(["bench/paper/run.py"] + list(argv)))
        meta, records = filter_report(meta, records, split_list(systems),
                                      split_list(strategies))
        prepare_out_dir(out_dir)
        with open(os.path.join(out_dir, "run.json"), "w", encoding="utf-8") as f:
            json.dump({"meta": meta, "trials": records}, f, indent=1)
    results = [r["result"] for r in records if r["status"] == "ok" and r["result"]]
    table_md, pngs = write_reports(out_dir, cfg, meta, records, results)
    print(table_md)
    for p in pngs:
        print("plot:", p)
    return 0


# --------------------------------------------------------------------------- main

OUTPUT_FILES = ["run.json", "results.csv", "trials.csv", "table.md", "summary.json",
                "server.log", "server.stdout", "rmse_all.png", "coverage.png"]


def snapshot_configs(trials, out_dir):
    """Copies each trial's system config into out_dir/configs and points the trial
    at the copy: what the trials run is what the run started with, even if the
    working tree's configs change while it runs (and the results keep them)."""
    copies = {}
    os.makedirs(os.path.join(out_dir, "configs"), exist_ok=True)
    for t in trials:
        if t.config not in copies:
            copies[t.config] = os.path.join(out_dir, "configs", os.path.basename(t.config))
            shutil.copyfile(t.config, copies[t.config])
        t.config = copies[t.config]


def prepare_out_dir(out_dir):
    """Creates the results directory. An earlier run's outputs in it (a directory
    with run.json) are removed first, so nothing stale is checked or plotted; any
    other non-empty directory is refused."""
    if os.path.isdir(out_dir) and os.listdir(out_dir):
        if not os.path.isfile(os.path.join(out_dir, "run.json")) and not os.path.isdir(
                os.path.join(out_dir, "trials")):
            sys.exit(f"run.py: {out_dir} exists and is not a results directory; "
                     "choose another --out")
        for name in os.listdir(out_dir):
            path = os.path.join(out_dir, name)
            if name in OUTPUT_FILES or re.fullmatch(
                    r"rmse_\w+\.png|server-\d+\.(log|stdout)", name):
                os.remove(path)
            elif name in ("trials", "configs") and os.path.isdir(path):
                shutil.rmtree(path)
    os.makedirs(out_dir, exist_ok=True)



def parse_args(argv):
    p = argparse.ArgumentParser(
        description="Runs the paper's benchmark (Table and Figure of Section 6) with "
        "real excite-server and excite-sim processes.")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true",
                      help="small sample budgets and 1-2 trials (< 10 min)")
    mode.add_argument("--ci", action="store_true",
                      help="pendulum + one MuJoCo system, tiny budgets, then check "
                      "the outputs (exit 1 on a problem)")
    p.add_argument("--systems", nargs="+", help="subset, e.g. pendulum,dipc")
    p.add_argument("--strategies", nargs="+", help="subset, e.g. rec pa greedy")
    p.add_argument("--trials", type=int, default=0, help="trials per pair (overrides)")
    p.add_argument("--samples", type=int, default=0, help="samples per trial (overrides)")
    p.add_argument("--session_override", default="",
                   help="SessionConfig textproto merged over every trial's session "
                        "(excite-sim --session_override), e.g. a variant's members")
    p.add_argument("--jobs", type=int, default=2, help="excite-sim processes at once")
    p.add_argument("--servers", type=int, default=0,
                   help="excite-server processes (default: --jobs); each server "
                   "serialises its Ipopt solves, so one per job lets planning "
                   "trials run in parallel")
    p.add_argument("--out", help="results directory (default results/paper/<timestamp>)")
    p.add_argument("--config", default=DEFAULT_CONFIG, help="benchmark settings (JSON)")
    p.add_argument("--server_bin", "--server-bin", dest="server_bin",
                   default=DEFAULT_SERVER)
    p.add_argument("--sim_bin", "--sim-bin", dest="sim_bin", default=DEFAULT_SIM)
    p.add_argument("--seed_offset", "--seed-offset", dest="seed_offset", type=int,
                   default=0, help="seed of trial k is seed_offset + k")
    p.add_argument("--trial_timeout", "--trial-timeout", dest="trial_timeout",
                   type=float, default=None, help="seconds; default from the config")
    p.add_argument("--keep_data", "--keep-data", dest="keep_data", action="store_true",
                   help="keep the server's temporary data directory")
    p.add_argument("--dry_run", "--dry-run", dest="dry_run", action="store_true",
                   help="print the plan (and what is missing) and exit")
    p.add_argument("--report_only", "--report-only", dest="report_only",
                   metavar="DIR", nargs="+",
                   help="re-aggregate and re-plot existing results: one results "
                   "directory (in place), or several directories and/or results.csv "
                   "files combined into --out (a later source's trial replaces an "
                   "earlier one with the same system, strategy and index); "
                   "--systems/--strategies select what is reported")
    return p.parse_args(argv)


def main(argv):
    args = parse_args(argv)
    cfg = load_config(args.config)
    if args.report_only:
        return report_only(args.report_only, cfg, args.out, args.systems,
                           args.strategies, argv)
    mode = "quick" if args.quick else "ci" if args.ci else "full"
    for b in (args.server_bin, args.sim_bin):
        if not os.access(b, os.X_OK):
            sys.exit(f"run.py: {b} not found or not executable; build first "
                     "(cmake --preset release && cmake --build --preset release -j2) "
                     "or pass --server_bin/--sim_bin")
    if args.trial_timeout is None:
        args.trial_timeout = float(cfg.get("trial_timeout_s", {}).get(mode, 0)) or None
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    out_dir = os.path.abspath(args.out or os.path.join(REPO, "results", "paper", stamp))

    trials, skipped, planned, samples_of, systems, strategies = make_plan(
        cfg, args, mode, out_dir)
    log(f"paper benchmark, {mode} mode: {len(trials)} trials, --jobs {args.jobs}, "
        f"results in {out_dir}")
    for system in systems:
        n = {st: planned[(system, st)] for st in strategies if (system, st) in planned}
        if n:
            log(f"  {system}: {samples_of.get(system)} samples; trials "
                + ", ".join(f"{st} {c}" for st, c in n.items()))
    for what, reason in condense_skipped(skipped):
        log(f"  NOT RUN {what}: {reason}")
    if args.dry_run:
        return 0
    if not trials:
        log("run.py: nothing to run")
        return 1
    prepare_out_dir(out_dir)
    snapshot_configs(trials, out_dir)

    meta = {
        "mode": mode, "started": datetime.datetime.now().isoformat(timespec="seconds"),
        "command": " ".join(["bench/paper/run.py"] + argv), "jobs": args.jobs,
        "servers": max(1, args.servers or args.jobs),
        "machine": machine_description(), "commit": git_commit(),
        "systems": systems, "strategies": strategies,
        "planned": {f"{k[0]}/{k[1]}": v for k, v in planned.items()},
        "samples": samples_of, "skipped": skipped,
        "overrides": "".join(
            f", {name} {value} (overrides benchmark.json)"
            for name, value in (("--trials", args.trials), ("--samples", args.samples),
                                ("--session_override", args.session_override))
            if value),
    }
    t0 = time.monotonic()
    n_servers = max(1, args.servers or args.jobs)
    servers = [Server(args.server_bin, out_dir, args.keep_data, i)
               for i in range(n_servers)]
    interrupted = False
    server_error = None
    try:
        for server in servers:
            address = server.wait_ready()
            log(f"excite-server listening on {address} (pid {server.proc.pid}), "
                f"data in {server.data_dir}")
        interrupted = run_trials(trials, args, servers, samples_of)
    except RuntimeError as e:
        server_error = str(e)
        log(f"run.py: {e}")
        for t in trials:
            if t.status == "running":
                try:
                    os.kill(t.proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                t.proc.wait()
                finish_trial(t)
            if t.status in ("queued", "running"):
                t.status, t.error = "skipped", "server failed"
    finally:
        codes = [server.stop() for server in servers]
    if any(codes) and not server_error:
        server_error = f"excite-server exit codes {codes} on SIGTERM"
        log(f"run.py: {server_error}")
    meta["wall_s"] = time.monotonic() - t0

    records = [trial_record(t) for t in trials]
    with open(os.path.join(out_dir, "run.json"), "w", encoding="utf-8") as f:
        json.dump({"meta": meta, "trials": records}, f, indent=1)
    results = [t.result for t in trials if t.status == "ok"]
    table_md, pngs = write_reports(out_dir, cfg, meta, records, results)
    log("")
    log(table_md)
    for p in pngs:
        log(f"plot: {p}")
    log(f"results: {out_dir} ({fmt_duration(meta['wall_s'])})")

    status = 0
    if interrupted or server_error or not results:
        status = 1
    if mode == "ci":
        ok_pairs = sorted({(t.system, t.strategy) for t in trials})
        problems = check.check_outputs(
            out_dir, ok_pairs,
            {s: cfg["systems"][s].get("label", s) for s in cfg["systems"]},
            cfg.get("strategy_labels", {}))
        failed = [t for t in trials if t.status != "ok"]
        problems += [f"{t.name()}: {t.status}: {t.error}" for t in failed]
        if "pendulum" not in {t.system for t in trials if t.status == "ok"}:
            problems.append("no successful pendulum trial")
        if not any(cfg["systems"][t.system].get("mujoco") for t in trials):
            log("note: no MuJoCo system exists yet; CI ran without one")
        if problems:
            log("CI check FAILED:")
            for pr in problems:
                log(f"  - {pr}")
            status = 1
        else:
            log(f"CI check passed: {len(ok_pairs)} system/strategy pairs, outputs "
                "well formed")
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
