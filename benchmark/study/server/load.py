"""Simulated participants for load tests of a running study server (``perf/study_load.py`` and
``tests/study/test_server_load.py``).

:func:`simulate` runs N concurrent clients (httpx, asyncio) for a bounded time; each client takes
part as one participant after another (consent, instructions, sound check, every question),
answering as fast as the server replies. A request that fails in transit (the server was
killed) is retried until the server is back; an answer retried after such a failure that the
server reports as already answered was written before the failure and counts as acknowledged.
:func:`check_against_store` compares the clients' acknowledged answers with the database.
"""

from __future__ import annotations

import asyncio
import os
import random
import subprocess
import sys
import threading
import time
from collections import Counter
from dataclasses import dataclass, field

__all__ = ["LoadResult", "simulate", "check_against_store", "percentile", "start_server", "load_run"]


@dataclass
class LoadResult:
    acknowledged: list[tuple[str, str, str, str, float]] = field(default_factory=list)  # token, trial, q, choice, t
    answer_seconds: list[float] = field(default_factory=list)   # response time of acknowledged answers
    request_seconds: list[float] = field(default_factory=list)  # every request that got a response
    transport_errors: int = 0
    statuses: Counter = field(default_factory=Counter)
    participants_started: int = 0
    participants_finished: int = 0
    finished_tokens: dict = field(default_factory=dict)  # token -> time.time() it finished


def percentile(values, q: float) -> float:
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, int(round(q / 100 * (len(ordered) - 1)))))]


async def _request(http, method: str, url: str, deadline: float, result: LoadResult, **kwargs):
    """The response, retrying transport errors (a killed server) until ``deadline``; None after it.
    Returns ``(response, retried)``."""
    import httpx

    retried = False
    while True:
        if time.monotonic() > deadline:
            return None, retried
        started = time.monotonic()
        try:
            response = await http.request(method, url, **kwargs)
        except httpx.TransportError:
            result.transport_errors += 1
            retried = True
            await asyncio.sleep(0.2)
            continue
        result.request_seconds.append(time.monotonic() - started)
        result.statuses[response.status_code] += 1
        return response, retried


async def _participant(http, deadline: float, result: LoadResult, sound_word: str, think: float, rng) -> None:
    response, _ = await _request(http, "POST", "/start", deadline, result, data={"consent": "yes"})
    if response is None:
        return
    if response.status_code != 303:
        raise RuntimeError(f"/start answered {response.status_code}: {response.text[:200]}")
    path = response.headers["location"]
    token = path.split("/")[2]
    result.participants_started += 1
    response, _ = await _request(http, "POST", f"{path}api/instructions", deadline, result)
    if response is None:
        return
    response, _ = await _request(http, "POST", f"{path}api/sound-check", deadline, result, json={"word": sound_word})
    if response is None:
        return
    while True:
        response, _ = await _request(http, "GET", f"{path}api/state", deadline, result)
        if response is None:
            return
        state = response.json()
        if state["step"] == "done":
            result.participants_finished += 1
            result.finished_tokens[token] = time.time()
            return
        if state["step"] != "question":  # e.g. the sound check again after a lost reply
            await _request(http, "POST", f"{path}api/sound-check", deadline, result, json={"word": sound_word})
            continue
        screen = state["screen"]
        body = {"trial": screen["trial"], "question": screen["question"],
                "choice": rng.choice(screen["choices"]), "rt_ms": rng.randint(500, 9000)}
        if think:
            await asyncio.sleep(rng.uniform(0, 2 * think))
        started = time.monotonic()
        response, retried = await _request(http, "POST", f"{path}api/answer", deadline, result, json=body)
        if response is None:
            return
        if response.status_code == 200 or (retried and response.status_code == 409
                                           and "already answered" in response.text):
            result.acknowledged.append((token, body["trial"], body["question"], body["choice"], time.time()))
            if response.status_code == 200 and not retried:  # a retried one's time includes the outage
                result.answer_seconds.append(time.monotonic() - started)
        elif response.status_code != 409:
            raise RuntimeError(f"answer refused with {response.status_code}: {response.text[:200]}")


async def _client(http, deadline, result, sound_word, think, seed):
    rng = random.Random(seed)
    while time.monotonic() < deadline:
        await _participant(http, deadline, result, sound_word, think, rng)


def simulate(base_url: str, clients: int, seconds: float, *, sound_word: str, think_seconds: float = 0.0,
             seed: int = 0, grace_seconds: float = 30.0) -> LoadResult:
    """Run ``clients`` simulated participants against ``base_url`` for ``seconds`` (answers
    stop being sent then; a request in flight may retry for ``grace_seconds`` more)."""
    import httpx

    result = LoadResult()

    async def main():
        limits = httpx.Limits(max_connections=clients + 8, max_keepalive_connections=clients + 8)
        async with httpx.AsyncClient(base_url=base_url, timeout=30.0, limits=limits) as http:
            stop = time.monotonic() + seconds
            await asyncio.gather(*(_client(http, stop, result, sound_word, think_seconds, seed * 1000 + k)
                                   for k in range(clients)))

    asyncio.run(main())
    return result


def check_against_store(result: LoadResult, store) -> dict:
    """Compare the acknowledged answers with the database: lost (acknowledged, not stored),
    duplicated (stored twice), stored but never acknowledged, and the counts."""
    from benchmark.study.server.store import token_sha256

    people = {p.id: p for p in store.all_participants()}
    by_hash = {}
    from sqlalchemy import select

    from benchmark.study.server.store import participants

    with store.engine.connect() as connection:
        for row in connection.execute(select(participants.c.id, participants.c.token_sha256)):
            by_hash[row[1]] = row[0]
    stored = Counter((a["participant_id"], a["trial"], a["question"], a["choice"]) for a in store.all_answers())
    acknowledged = Counter((by_hash.get(token_sha256(t)), trial, q, c) for t, trial, q, c, _ in result.acknowledged)
    lost = sum((acknowledged - stored).values())
    return {"acknowledged": sum(acknowledged.values()), "stored": sum(stored.values()), "lost": lost,
            "duplicated": sum(n - 1 for n in stored.values() if n > 1),
            "acknowledged_twice": sum(n - 1 for n in acknowledged.values() if n > 1),
            "stored_not_acknowledged": sum((stored - acknowledged).values()), "participants": len(people)}


def start_server(folder, port: int, db_url: str | None = None, timeout: float = 90.0) -> subprocess.Popen:
    """``python -m benchmark.study serve FOLDER --port PORT`` as a child process, once it answers."""
    import httpx

    from pathlib import Path

    root = Path(__file__).resolve().parents[3]
    command = [sys.executable, "-m", "benchmark.study", "serve", str(folder), "--port", str(port)]
    if db_url:
        command += ["--db", db_url]
    env = {**os.environ, "PYTHONPATH": str(root) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    deadline = time.monotonic() + timeout
    while True:
        if process.poll() is not None:
            raise RuntimeError(f"the study server exited: {process.stdout.read()}")
        try:
            if httpx.get(f"http://127.0.0.1:{port}/", timeout=2).status_code == 200:
                return process
        except httpx.HTTPError:
            pass
        if time.monotonic() > deadline:
            process.kill()
            raise RuntimeError(f"the study server did not answer in {timeout} s")
        time.sleep(0.1)


def load_run(folder, *, clients: int, seconds: float, sound_word: str, kill_at: float | None = None,
             port: int, db_url: str | None = None, think_seconds: float = 0.0, seed: int = 0) -> dict:
    """Serve ``folder`` in a child process, run :func:`simulate` against it, and (``kill_at``
    seconds in) kill the server with SIGKILL and start it again. Returns the figures:
    response times, the database check, and how many interrupted participants resumed."""
    from benchmark.study.server.store import open_store

    server = {"process": start_server(folder, port, db_url)}
    events = {}

    def killer():
        time.sleep(kill_at)
        events["kill"] = time.time()
        server["process"].kill()  # SIGKILL: no shutdown, no flush
        server["process"].wait()
        events["dead"] = time.time()  # what is acknowledged from now on, the restarted server acknowledged
        server["process"] = start_server(folder, port, db_url)
        events["restarted"] = time.time()

    thread = threading.Thread(target=killer, daemon=True) if kill_at is not None else None
    if thread:
        thread.start()
    try:
        result = simulate(f"http://127.0.0.1:{port}", clients, seconds, sound_word=sound_word,
                          think_seconds=think_seconds, seed=seed)
        if thread:
            thread.join(120)
    finally:
        if thread:
            thread.join(120)
        server["process"].terminate()
        try:
            server["process"].wait(20)
        except subprocess.TimeoutExpired:
            server["process"].kill()
    store = open_store(folder, db_url)
    try:
        figures = check_against_store(result, store)
    finally:
        store.close()
    figures.update(
        clients=clients, seconds=seconds, answers_per_second=len(result.acknowledged) / seconds,
        answer_p50_ms=1000 * percentile(result.answer_seconds, 50),
        answer_p99_ms=1000 * percentile(result.answer_seconds, 99),
        request_p50_ms=1000 * percentile(result.request_seconds, 50),
        request_p99_ms=1000 * percentile(result.request_seconds, 99),
        transport_errors=result.transport_errors, statuses=dict(result.statuses),
        participants_started=result.participants_started, participants_finished=result.participants_finished)
    if "kill" in events:
        kill = events["kill"]
        acks_by_token = {}
        for token, _, _, _, moment in result.acknowledged:
            acks_by_token.setdefault(token, []).append(moment)
        interrupted = {t for t, moments in acks_by_token.items()
                       if min(moments) < kill and result.finished_tokens.get(t, float("inf")) > kill}
        # resumed: answered again once the killed server was gone (only the restarted one can have
        # acknowledged it; not from when start_server saw it answer, which a quick participant may
        # have used to finish), or found its last answer stored and finished
        resumed = {t for t in interrupted if max(acks_by_token[t]) > events["dead"]
                   or result.finished_tokens.get(t, 0) > events["dead"]}
        figures.update(killed_after_s=kill_at, restart_s=events["restarted"] - kill,
                       interrupted=len(interrupted), resumed=len(resumed),
                       acknowledged_before_kill=sum(m < kill for ms in acks_by_token.values() for m in ms))
    return figures
