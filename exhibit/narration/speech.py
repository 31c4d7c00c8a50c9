"""Offline speech with espeak-ng, for the texts a curator has not recorded.

Why espeak-ng: it is in Debian main (so bootstrap.sh installs it, and an offline bundle carries
it as .debs), needs no network or model download, speaks English and German (and a hundred more
languages the catalogues may add), and is fast enough to speak every shipped text while scenes
are prepared. It sounds synthetic; a museum that wants warmth records its narration, which wins
wherever it exists. Neural engines (Piper) need voice models from outside the package
registries, and the better MBROLA voices are not in Debian main.

The engine runs as a subprocess, never through a shell: the text goes in on stdin (so one that
begins with "-" is not an option), the WAV comes back on stdout, with a timeout and a cap on its
size.
"""

from __future__ import annotations

import functools
import os
import selectors
import shutil
import subprocess
import time

from exhibit.narration.errors import NarrationError
from exhibit.narration.sound import Sound, read_wav_bytes

ENGINE = "espeak-ng"
#: Language -> espeak-ng voice. en-gb is espeak-ng's own English: its rules and dictionary are
#: written for it (the American and regional voices are variants on top), and it is what "en"
#: resolves to; "de" is its only German voice without MBROLA.
VOICES = {"en": "en-gb", "de": "de"}
#: A description or caption longer than this is a mistake, not a text to read for minutes.
MAX_TEXT_CHARS = 2000
#: The most a synthesis may take and return (10 minutes of 16-bit audio at 22.05 kHz).
TIMEOUT_S = 60.0
MAX_OUTPUT_BYTES = 600 * 22050 * 2
INSTALL_HINT = "apt-get install espeak-ng (./bootstrap.sh installs it)"


def _binary() -> str | None:
    return shutil.which(ENGINE)


def available() -> bool:
    """Whether espeak-ng can be run here."""
    return _binary() is not None


@functools.lru_cache(maxsize=1)
def _version(binary: str) -> str:
    try:
        out = subprocess.run(
            [binary, "--version"], capture_output=True, timeout=10, check=False, env=_env()
        ).stdout.decode("utf-8", "replace")
    except (OSError, subprocess.SubprocessError) as exc:
        raise NarrationError(f"{ENGINE} --version failed: {exc}") from None
    # "eSpeak NG text-to-speech: 1.51  Data at: ..."
    words = out.split("text-to-speech:", 1)[-1].split()
    return words[0] if words else out.strip() or "unknown"


def engine_version() -> str:
    """espeak-ng's version ("1.51"); part of the speech cache's key."""
    binary = _binary()
    if binary is None:
        raise NarrationError(f"{ENGINE} is not installed: {INSTALL_HINT}")
    return _version(binary)


def _env() -> dict[str, str]:
    """A plain C environment: espeak-ng must not pick up a user's config or audio settings."""
    return {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "LC_ALL": "C.UTF-8"}


def _shown(text: str) -> str:
    words = " ".join(text.split())
    return repr(words if len(words) <= 40 else words[:37] + "...")


def voice_for(language: str) -> str:
    """The espeak-ng voice of ``language``; NarrationError when it has none."""
    voice = VOICES.get(language) if isinstance(language, str) else None
    if voice is None:
        have = ", ".join(sorted(VOICES))
        raise NarrationError(f"no {ENGINE} voice for language {language!r} (have: {have})")
    return voice


def synthesise(text: str, language: str, rate_wpm: int = 150) -> Sound:
    """``text`` spoken in ``language`` (a key of VOICES) at ``rate_wpm`` words a minute.
    NarrationError, on one line, when espeak-ng is missing, the language has no voice, the text
    is blank or too long, or espeak-ng fails."""
    voice = voice_for(language)
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
    command = [binary, "--stdout", "-b", "1", "-v", voice, "-s", str(int(rate_wpm))]
    data = _run(command, text.encode("utf-8"), _shown(text))
    return read_wav_bytes(data, f"{ENGINE} output for {_shown(text)}")


def _run(command: list[str], stdin: bytes, shown: str) -> bytes:
    """Run ``command`` with ``stdin``; its stdout, read to MAX_OUTPUT_BYTES within TIMEOUT_S."""
    try:
        proc = subprocess.Popen(
            command,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env=_env(),
            start_new_session=True,
        )
    except OSError as exc:
        raise NarrationError(f"cannot run {ENGINE}: {exc.strerror or exc}") from None
    out, err = bytearray(), bytearray()
    try:
        assert proc.stdin and proc.stdout and proc.stderr
        try:
            proc.stdin.write(stdin)  # MAX_TEXT_CHARS fits the pipe's buffer: no deadlock
            proc.stdin.close()
        except BrokenPipeError:
            pass
        deadline = time.monotonic() + TIMEOUT_S
        with selectors.DefaultSelector() as sel:
            sel.register(proc.stdout, selectors.EVENT_READ, out)
            sel.register(proc.stderr, selectors.EVENT_READ, err)
            while sel.get_map():
                left = deadline - time.monotonic()
                if left <= 0:
                    raise NarrationError(f"{ENGINE} took over {TIMEOUT_S:g} s to speak {shown}")
                for key, _ in sel.select(left):
                    chunk = os.read(key.fd, 1 << 16)
                    if not chunk:
                        sel.unregister(key.fileobj)
                        continue
                    key.data.extend(chunk)
                    if len(out) > MAX_OUTPUT_BYTES or len(err) > 1 << 16:
                        raise NarrationError(
                            f"{ENGINE} wrote over {MAX_OUTPUT_BYTES} bytes for {shown}"
                        )
        code = proc.wait(timeout=max(0.1, deadline - time.monotonic()))
    except subprocess.TimeoutExpired:
        raise NarrationError(f"{ENGINE} took over {TIMEOUT_S:g} s to speak {shown}") from None
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        for stream in (proc.stdout, proc.stderr):
            if stream:
                stream.close()
    if code != 0 or not out:
        why = " ".join(err.decode("utf-8", "replace").split())[:200] or f"exit status {code}"
        raise NarrationError(f"{ENGINE} failed to speak {shown}: {why}")
    return bytes(out)
