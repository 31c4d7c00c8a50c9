"""Offline speech with espeak-ng, for the texts a curator has not recorded.

Why espeak-ng: it is in Debian main (so bootstrap.sh installs it, and an offline bundle carries
it as .debs), needs no network or model download, speaks English, German and French (and a
hundred more languages a catalogue may add, naming its voice: exhibit.kiosk.language), and is
fast enough to speak every shipped text while scenes are prepared. It sounds synthetic; a museum
that wants warmth records its narration, which wins wherever it exists. Neural engines (Piper)
need voice models from outside the package registries, and the better MBROLA voices are not in
Debian main.

The engine runs as a subprocess, never through a shell: the text goes in on stdin (so one that
begins with "-" is not an option), the WAV comes back on stdout, with a cap on its size, in a
process group of its own that is killed when the call ends or the exhibit does
(exhibit.tools). Its time is a :class:`SpeechBudget`: each call at most
exhibit.tools.ESPEAK_CALL_S, a command's calls together at most SPEECH_TOTAL_S, and once the
engine has hung every later call of the same run fails at once with the same reason. What it
says is brought to narration's loudness (exhibit.narration.loudness), as a recording is.
"""

from __future__ import annotations

import os
import shutil
import threading
import time
from dataclasses import dataclass

from exhibit import tools
from exhibit.narration import loudness
from exhibit.narration.errors import NarrationError
from exhibit.narration.sound import Sound, read_wav_bytes

ENGINE = "espeak-ng"
#: Words a minute, when a language's voice does not say.
DEFAULT_RATE_WPM = 150


@dataclass(frozen=True)
class Voice:
    """How espeak-ng speaks one language: its voice (``espeak-ng --voices=fr`` lists a
    language's) and the rate in words a minute. A language's voice is data: the ``[voice]``
    table of its catalogue (exhibit.kiosk.language), registered here as the catalogue loads."""

    name: str
    rate_wpm: int = DEFAULT_RATE_WPM


#: English, the source language, has no catalogue: its voice is en-gb, espeak-ng's own English
#: (its rules and dictionary are written for it; the American and regional voices are variants
#: on top), and what "en" resolves to. Every other language's voice comes from its catalogue.
SOURCE_VOICES = {"en": Voice("en-gb")}
_voices: dict[str, Voice] = dict(SOURCE_VOICES)
_voices_lock = threading.Lock()


def set_voice(language: str, voice: Voice) -> None:
    """``language`` is spoken with ``voice`` from now on (a catalogue that loads says so)."""
    with _voices_lock:
        _voices[language] = voice


def voices() -> dict[str, Voice]:
    """Every language with a voice: English and each catalogue loaded so far."""
    with _voices_lock:
        return dict(_voices)


#: A description or caption longer than this is a mistake, not a text to read for minutes.
MAX_TEXT_CHARS = 2000
#: The most a synthesis may return (10 minutes of 16-bit audio at 22.05 kHz); its time limits
#: are exhibit.tools.ESPEAK_CALL_S and SPEECH_TOTAL_S, with the other tools' limits.
MAX_OUTPUT_BYTES = 600 * 22050 * 2
INSTALL_HINT = "apt-get install espeak-ng (./bootstrap.sh installs it)"


def _binary() -> str | None:
    return shutil.which(ENGINE)


def available() -> bool:
    """Whether espeak-ng can be run here."""
    return _binary() is not None


class SpeechSkipped(NarrationError):
    """Not spoken, without asking the engine: it hung, or the run's time for speech ran out,
    earlier in the same run; ``reason`` is that first failure's message."""

    def __init__(self, reason: str) -> None:
        super().__init__(f"skipped: {reason}")
        self.reason = reason


class SpeechBudget:
    """The time espeak-ng may take in one run, shared by its threads: each call at most
    ``call_s`` seconds (default exhibit.tools.ESPEAK_CALL_S), all calls together at most
    ``total_s`` (None: no total, as in the kiosk, which runs for weeks; a command uses
    :meth:`for_command`). The first call that runs out of time sets :attr:`reason`
    ("espeak-ng did not answer within 20 s (speaking '...')"); every later call raises
    SpeechSkipped with it at once and is counted in :attr:`skipped`, so a hung engine costs
    ``call_s`` once, not once a segment. A kiosk tries the engine again at its next start."""

    def __init__(self, call_s: float | None = None, total_s: float | None = None) -> None:
        self.call_s = tools.ESPEAK_CALL_S if call_s is None else float(call_s)
        self.total_s = total_s
        self.spent_s = 0.0
        self.reason: str | None = None
        self.skipped = 0
        self._lock = threading.Lock()

    @classmethod
    def for_command(cls) -> SpeechBudget:
        """A command's budget: exhibit.tools.ESPEAK_CALL_S a call, SPEECH_TOTAL_S in all."""
        return cls(total_s=tools.SPEECH_TOTAL_S)

    def _stop(self, reason: str) -> NarrationError:
        with self._lock:
            if self.reason is None:
                self.reason = reason
        return NarrationError(reason)

    def run(self, command: list[str], stdin: bytes, doing: str) -> tools.Finished:
        """``command`` run within what is left (``doing``: "speaking 'Hello'", for the
        message); NarrationError when it runs out of time or cannot be run."""
        with self._lock:
            if self.reason is not None:
                self.skipped += 1
                raise SpeechSkipped(self.reason)
            limit, whole = self.call_s, False
            if self.total_s is not None and self.total_s - self.spent_s < limit:
                limit, whole = self.total_s - self.spent_s, True
        if limit <= 0:
            raise self._stop(self._over(doing))
        begun = time.monotonic()
        try:
            return tools.run(command, stdin, limit_s=limit, max_out=MAX_OUTPUT_BYTES, env=_env())
        except tools.ToolHung:
            raise self._stop(
                self._over(doing)
                if whole
                else f"{ENGINE} did not answer within {limit:g} s ({doing})"
            ) from None
        except tools.ToolOutputTooLarge as exc:
            raise NarrationError(f"{ENGINE} wrote over {exc.limit} bytes {doing}") from None
        except OSError as exc:
            raise NarrationError(f"cannot run {ENGINE}: {exc.strerror or exc}") from None
        finally:
            with self._lock:
                self.spent_s += time.monotonic() - begun

    def _over(self, doing: str) -> str:
        return (
            f"{ENGINE} took over {self.total_s:g} s in all, the most a run's speech may take "
            f"(a slow or overloaded machine; stopped {doing})"
        )


#: espeak-ng's version by binary, once it has answered.
_versions: dict[str, str] = {}


def _version(binary: str, budget: SpeechBudget | None = None) -> str:
    if binary not in _versions:
        budget = budget or SpeechBudget()
        done = budget.run([binary, "--version"], b"", "asked its version")
        out = tools.text(done.out)
        if done.code != 0:
            why = " ".join(tools.text(done.err).split())[:200] or f"exit status {done.code}"
            raise NarrationError(f"{ENGINE} --version failed: {why}")
        # "eSpeak NG text-to-speech: 1.51  Data at: ..."
        words = out.split("text-to-speech:", 1)[-1].split()
        _versions[binary] = words[0] if words else out.strip() or "unknown"
    return _versions[binary]


#: How synthesised speech is made after espeak-ng: its loudness target and true-peak ceiling
#: (exhibit.narration.loudness). Part of :func:`engine_version`, so speech cached at another
#: level (or before it was measured at all) misses and is made again.
PROCESSING = f"bs1770 {loudness.TARGET_LUFS:g} LUFS {loudness.CEILING_DBTP:g} dBTP"


def engine_version(budget: SpeechBudget | None = None) -> str:
    """What makes the speech, by version: espeak-ng's ("1.51") and :data:`PROCESSING`
    ("1.51; bs1770 -23 LUFS -1 dBTP"); part of the speech cache's key. ``budget``: the run's
    (default: one call's limit)."""
    binary = _binary()
    if binary is None:
        raise NarrationError(f"{ENGINE} is not installed: {INSTALL_HINT}")
    return f"{_version(binary, budget)}; {PROCESSING}"


def _env() -> dict[str, str]:
    """A plain C environment: espeak-ng must not pick up a user's config or audio settings."""
    return {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "LC_ALL": "C.UTF-8"}


def _shown(text: str) -> str:
    words = " ".join(text.split())
    return repr(words if len(words) <= 40 else words[:37] + "...")


def _shipped_voice(language: str) -> Voice | None:
    """The [voice] of the shipped catalogue of ``language`` (configs/languages/<code>.toml),
    for a language whose catalogue has not been loaded (a command speaking a text alone)."""
    import re
    import tomllib

    from exhibit.resources import shipped

    if not re.fullmatch(r"[a-z]{2,3}(-[A-Z]{2})?", language):
        return None
    try:
        doc = tomllib.loads(shipped("configs", "languages", f"{language}.toml").read_text("utf-8"))
    except (OSError, UnicodeError, tomllib.TOMLDecodeError):
        return None
    table = doc.get("voice", {})
    name = table.get("name", language) if isinstance(table, dict) else language
    rate = table.get("rate_wpm", DEFAULT_RATE_WPM) if isinstance(table, dict) else 0
    if not isinstance(name, str) or not isinstance(rate, int):
        return None
    return Voice(name, rate)


def voice_for(language: str) -> Voice:
    """The voice of ``language``: its catalogue's (registered as it loaded, else the shipped
    catalogue's); NarrationError when it has none."""
    voice = voices().get(language) if isinstance(language, str) else None
    if voice is None and isinstance(language, str):
        voice = _shipped_voice(language)
        if voice is not None:
            set_voice(language, voice)
    if voice is None:
        have = ", ".join(sorted(voices()))
        raise NarrationError(
            f"no {ENGINE} voice for language {language!r} (have: {have}; a language's voice "
            "is the [voice] of its catalogue, configs/languages/<code>.toml)"
        )
    return voice


def synthesise(
    text: str, language: str, rate_wpm: int | None = None, budget: SpeechBudget | None = None
) -> Sound:
    """``text`` spoken in ``language`` (with :func:`voice_for`'s voice) at ``rate_wpm`` words a
    minute (default: the voice's rate), within
    ``budget`` (the run's; default: one call's limit). NarrationError, on one line, when
    espeak-ng is missing, the language has no voice, the text is blank or too long, or
    espeak-ng fails or runs out of time (SpeechSkipped when it did so earlier in the run)."""
    voice = voice_for(language)
    if rate_wpm is None:
        rate_wpm = voice.rate_wpm
    if not isinstance(text, str) or not text.strip():
        raise NarrationError("cannot speak a blank text")
    if len(text) > MAX_TEXT_CHARS:
        raise NarrationError(
            f"text {_shown(text)} is {len(text)} characters, over the {MAX_TEXT_CHARS} spoken"
        )
    if "\0" in text:
        raise NarrationError(f"text {_shown(text)} holds a NUL character")
    if not 80 <= rate_wpm <= 450:
        raise NarrationError(f"speech rate {rate_wpm} words a minute: 80 to 450 are possible")
    binary = _binary()
    if binary is None:
        raise NarrationError(f"{ENGINE} is not installed: {INSTALL_HINT}")
    command = [binary, "--stdout", "-b", "1", "-v", voice.name, "-s", str(int(rate_wpm))]
    shown = _shown(text)
    done = (budget or SpeechBudget()).run(command, text.encode("utf-8"), f"speaking {shown}")
    if done.code != 0 or not done.out:
        why = " ".join(tools.text(done.err).split())[:200] or f"exit status {done.code}"
        raise NarrationError(f"{ENGINE} failed to speak {shown}: {why}")
    return loudness.normalise(read_wav_bytes(done.out, f"{ENGINE} output for {shown}"))
