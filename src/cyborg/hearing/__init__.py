"""The robot's ears: offline speech recognition that publishes what it hears on ``/text_from_speech``.

:mod:`~cyborg.hearing.grammar` builds what the robot can hear from what it understands (pure),
:mod:`~cyborg.hearing.understanding` says what the robot would do with a sentence (pure),
:mod:`~cyborg.hearing.whisper` decodes with Whisper tiny.en (the default) and believes what the
robot understands, :mod:`~cyborg.hearing.rescoring` says which candidate transcripts its second look
scores (pure), :mod:`~cyborg.hearing.recogniser` decodes with pocketsphinx and rejects
speech outside the grammar, :mod:`~cyborg.hearing.vad` cuts audio into utterances with Silero
VAD, :mod:`~cyborg.hearing.audio` reads WAV files and the microphone,
:mod:`~cyborg.hearing.synth` synthesises speech (espeak-ng, flite) for tests and benchmarks of the ears, and
:mod:`~cyborg.hearing.module` is the ``speech_input`` module kind.
"""

from cyborg.errors import CyborgError

__all__ = ["HearingError"]


class HearingError(CyborgError):
    """Speech input cannot work: no audio library, no microphone, no (or a broken) model, or an unreadable recording."""
