"""The answers' store: participants and their answers in SQLite (default) or PostgreSQL.

Two tables (SQLAlchemy 2 Core): ``participants`` (slot, session token's sha256, platform id,
start/finish times, consent, sound check) and ``answers`` (one row per question of a trial,
unique on ``(participant, trial, question)``). Every write is its own transaction, committed
before the call returns, so an answer acknowledged to a browser survives a crash of the server.

SQLite runs in WAL mode with ``synchronous=FULL`` and a busy timeout (several threads write);
PostgreSQL is reached with ``postgresql://...`` (the psycopg 3 driver).
"""

from __future__ import annotations

import hashlib
import secrets
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from sqlalchemy import (
    Boolean,
    Column,
    DateTime,
    ForeignKey,
    Integer,
    MetaData,
    String,
    Table,
    UniqueConstraint,
    create_engine,
    event,
    func,
    insert,
    select,
    update,
)
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError, IntegrityError, NoSuchModuleError, OperationalError

from blendvoca.errors import UserError

__all__ = ["DB_FILE", "AlreadyAnswered", "Participant", "Store", "default_db_url", "open_store", "token_sha256"]

#: The default database, inside the study folder.
DB_FILE = "answers.sqlite"

metadata = MetaData()

participants = Table(
    "participants", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("public_id", String(32), nullable=False, unique=True),
    Column("token_sha256", String(64), nullable=False, unique=True),
    Column("slot", Integer, nullable=False, index=True),
    Column("platform", String(16), nullable=True),
    Column("platform_id", String(64), nullable=True, index=True),
    Column("platform_study", String(64), nullable=True),
    Column("platform_session", String(64), nullable=True),
    Column("completion_code", String(32), nullable=False),
    Column("started_at", DateTime(timezone=True), nullable=False),
    Column("instructions_read_at", DateTime(timezone=True), nullable=True),
    Column("sound_check_attempts", Integer, nullable=False, default=0),
    Column("sound_check_passed", Boolean, nullable=True),
    Column("finished_at", DateTime(timezone=True), nullable=True),
)

answers = Table(
    "answers", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("participant_id", Integer, ForeignKey("participants.id"), nullable=False, index=True),
    Column("trial", String(128), nullable=False),
    Column("question", String(64), nullable=False),
    Column("choice", String(16), nullable=False),
    Column("rt_ms", Integer, nullable=True),
    Column("answered_at", DateTime(timezone=True), nullable=False),
    UniqueConstraint("participant_id", "trial", "question", name="one_answer_per_question"),
)


class AlreadyAnswered(Exception):
    """The participant already answered this question of this trial."""


@dataclass(frozen=True)
class Participant:
    id: int
    public_id: str
    slot: int
    platform: str | None
    platform_id: str | None
    completion_code: str
    started_at: datetime
    instructions_read_at: datetime | None
    sound_check_attempts: int
    sound_check_passed: bool | None
    finished_at: datetime | None


def now() -> datetime:
    return datetime.now(timezone.utc)


def utc(moment: datetime | None) -> datetime | None:
    """SQLite gives naive datetimes back: they were written in UTC."""
    if moment is not None and moment.tzinfo is None:
        return moment.replace(tzinfo=timezone.utc)
    return moment


def token_sha256(token: str) -> str:
    """The session token's digest, which is all the database keeps of it."""
    return hashlib.sha256(token.encode("utf-8", "surrogatepass")).hexdigest()


def default_db_url(folder) -> str:
    return f"sqlite:///{(Path(folder) / DB_FILE).resolve()}"


def _sqlite_pragmas(dbapi_connection, _record) -> None:
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute("PRAGMA synchronous=FULL")
    cursor.execute("PRAGMA busy_timeout=30000")
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.close()


def _participant(row) -> Participant:
    return Participant(id=row.id, public_id=row.public_id, slot=row.slot, platform=row.platform,
                       platform_id=row.platform_id, completion_code=row.completion_code,
                       started_at=utc(row.started_at), instructions_read_at=utc(row.instructions_read_at),
                       sound_check_attempts=row.sound_check_attempts, sound_check_passed=row.sound_check_passed,
                       finished_at=utc(row.finished_at))


class Store:
    """The study's database (see the module docstring); thread-safe through the engine's pool."""

    def __init__(self, url: str):
        try:
            parsed = make_url(url)
        except ArgumentError:
            raise UserError(f"--db {url!r}: not a database URL; expected sqlite:///PATH or "
                            "postgresql://USER@HOST:PORT/NAME") from None
        backend = parsed.get_backend_name()
        if backend not in ("sqlite", "postgresql"):
            raise UserError(f"--db {parsed.render_as_string(hide_password=True)}: expected a sqlite:/// or "
                            f"postgresql:// URL, found {backend}://")
        if backend == "postgresql" and parsed.drivername == "postgresql":
            parsed = parsed.set(drivername="postgresql+psycopg")
        self.url = parsed
        kwargs = {"future": True}
        if backend == "sqlite":
            kwargs["connect_args"] = {"check_same_thread": False, "timeout": 30}
        else:
            kwargs.update(pool_size=10, max_overflow=40, pool_pre_ping=True)
        try:
            self.engine = create_engine(parsed, **kwargs)
        except NoSuchModuleError as error:
            raise UserError(f"--db: {error}") from None
        if backend == "sqlite":
            event.listen(self.engine, "connect", _sqlite_pragmas)
        try:
            metadata.create_all(self.engine)
        except OperationalError as error:
            where = parsed.render_as_string(hide_password=True)
            raise UserError(f"--db {where}: cannot open the database ({str(error.orig).strip()})") from None

    def close(self) -> None:
        self.engine.dispose()

    # -- participants ---------------------------------------------------------------------------

    def slot_loads(self) -> dict[int, tuple[int, int]]:
        """slot -> (finished participants, all participants) given that slot so far."""
        with self.engine.connect() as connection:
            rows = connection.execute(
                select(participants.c.slot, func.count(participants.c.finished_at), func.count())
                .group_by(participants.c.slot)).all()
        return {row[0]: (row[1], row[2]) for row in rows}

    def add_participant(self, slots: list[int], platform: str | None, platform_id: str | None,
                        platform_study: str | None = None, platform_session: str | None = None,
                        completion_code: str | None = None) -> tuple[str, Participant]:
        """A new participant on the least-taken slot: ``(session token, participant)``.

        Slots are given round-robin: the slot with the fewest finished participants, then the
        fewest participants at all, then the lowest number. The token is returned once; the
        database keeps its sha256 only.
        """
        token = secrets.token_urlsafe(32)
        for _attempt in range(5):
            loads = self.slot_loads()
            slot = min(slots, key=lambda s: (*loads.get(s, (0, 0)), s))
            values = dict(public_id="p" + secrets.token_hex(6), token_sha256=token_sha256(token), slot=slot,
                          platform=platform, platform_id=platform_id, platform_study=platform_study,
                          platform_session=platform_session,
                          completion_code=completion_code or secrets.token_hex(4).upper(),
                          started_at=now(), sound_check_attempts=0)
            try:
                with self.engine.begin() as connection:
                    connection.execute(insert(participants).values(**values))
                    row = connection.execute(select(participants).where(
                        participants.c.token_sha256 == values["token_sha256"])).one()
                return token, _participant(row)
            except IntegrityError:  # a public id drawn twice (1 in 2^48): draw again
                token = secrets.token_urlsafe(32)
        raise RuntimeError("could not add a participant")

    def participant_by_token(self, token: str) -> Participant | None:
        with self.engine.connect() as connection:
            row = connection.execute(select(participants).where(
                participants.c.token_sha256 == token_sha256(token))).one_or_none()
        return None if row is None else _participant(row)

    def participant_by_platform(self, platform: str, platform_id: str) -> tuple[Participant, str | None] | None:
        """The participant who started with this platform id, and the platform session they started in."""
        with self.engine.connect() as connection:
            row = connection.execute(select(participants).where(
                participants.c.platform == platform, participants.c.platform_id == platform_id)
                .order_by(participants.c.id)).first()
        return None if row is None else (_participant(row), row.platform_session)

    def new_token(self, participant_id: int) -> str:
        """Replace a participant's session token (the old one stops working)."""
        token = secrets.token_urlsafe(32)
        with self.engine.begin() as connection:
            connection.execute(update(participants).where(participants.c.id == participant_id)
                               .values(token_sha256=token_sha256(token)))
        return token

    def mark_instructions_read(self, participant_id: int) -> None:
        with self.engine.begin() as connection:
            connection.execute(update(participants).where(participants.c.id == participant_id,
                                                          participants.c.instructions_read_at.is_(None))
                               .values(instructions_read_at=now()))

    def record_sound_check(self, participant_id: int, passed: bool, max_attempts: int) -> Participant:
        """Count one attempt; ``sound_check_passed`` becomes True on a pass, False after the last try."""
        with self.engine.begin() as connection:
            row = connection.execute(select(participants).where(participants.c.id == participant_id)
                                     .with_for_update()).one()
            if row.sound_check_passed is None:
                attempts = row.sound_check_attempts + 1
                verdict = True if passed else (False if attempts >= max_attempts else None)
                connection.execute(update(participants).where(participants.c.id == participant_id)
                                   .values(sound_check_attempts=attempts, sound_check_passed=verdict))
            row = connection.execute(select(participants).where(participants.c.id == participant_id)).one()
        return _participant(row)

    def mark_finished(self, participant_id: int) -> None:
        with self.engine.begin() as connection:
            connection.execute(update(participants).where(participants.c.id == participant_id,
                                                          participants.c.finished_at.is_(None))
                               .values(finished_at=now()))

    # -- answers --------------------------------------------------------------------------------

    def answered(self, participant_id: int) -> set[tuple[str, str]]:
        """The ``(trial, question)`` pairs this participant has answered."""
        with self.engine.connect() as connection:
            rows = connection.execute(select(answers.c.trial, answers.c.question)
                                      .where(answers.c.participant_id == participant_id)).all()
        return {(row[0], row[1]) for row in rows}

    def add_answer(self, participant_id: int, trial: str, question: str, choice: str, rt_ms: int | None) -> None:
        """Write one answer in its own transaction; :class:`AlreadyAnswered` if it was given before."""
        try:
            with self.engine.begin() as connection:
                connection.execute(insert(answers).values(participant_id=participant_id, trial=trial,
                                                          question=question, choice=choice, rt_ms=rt_ms,
                                                          answered_at=now()))
        except IntegrityError:
            raise AlreadyAnswered(f"{trial}/{question}") from None

    # -- everything, for the export -----------------------------------------------------------

    def all_participants(self) -> list[Participant]:
        with self.engine.connect() as connection:
            rows = connection.execute(select(participants).order_by(participants.c.id)).all()
        return [_participant(row) for row in rows]

    def all_answers(self) -> list[dict]:
        with self.engine.connect() as connection:
            rows = connection.execute(select(answers).order_by(answers.c.id)).all()
        return [{"participant_id": r.participant_id, "trial": r.trial, "question": r.question, "choice": r.choice,
                 "rt_ms": r.rt_ms, "answered_at": utc(r.answered_at)} for r in rows]

    def count_answers(self) -> int:
        with self.engine.connect() as connection:
            return connection.execute(select(func.count()).select_from(answers)).scalar_one()


def open_store(folder, db_url: str | None = None) -> Store:
    """The store of the study in ``folder``: ``--db URL`` or ``STUDY/answers.sqlite``."""
    return Store(db_url or default_db_url(folder))
