"""``skatelib track LIB --plant mujoco --entry K --draw SEED``: one ride of a certificate again (the
draw of SEED: its model errors, shove and noise), judged as the certificate judged it, with
``--video`` rendered. The distributions are the library's certificate's (the ones the seed was
drawn from), or the ``[certify]`` table of the library's config when it has no certificate."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.markup import escape
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.views.console import console
from skatelib.pipeline.views.verdict_tables import twin_table


def track_draw(library: Path, keys: list[str] | None, seed: int, where: tuple[bool, Path | None],
               controller: tuple[list[str], list[str], Any]) -> None:
    """Ride entry ``keys[0]`` under the draw of ``seed``; exit 1 when it fails. ``where``: on the
    twin, and a video to render; ``controller``: the options given that a draw does not take (its
    errors, noise, state and outputs are the certificate's: refused), the controller's options
    given (a ride under another controller than the certificate's: said so), and the MPC's config."""
    refused, changed, mpc = controller
    on_twin, video = where
    if refused:
        raise typer.BadParameter(f"--draw rides the certificate's draw as it was drawn (its errors, shove, noise "
                                 f"and state) and writes a video at most: leave out {', '.join(refused)}",
                                 param_hint="--draw")
    from skatelib.pipeline.certify_spec import library_spec
    from skatelib.proving.certify.draw import make_draw
    from skatelib.proving.certify.ride import ride_draw
    from skatelib.proving.certify.spec import CertifySpec
    from skatelib.proving.twin.track import check_twin

    if not on_twin or not keys or len(keys) != 1:
        raise SkatelibError("--draw rides one draw of a certificate on the twin: give --plant mujoco and one --entry")
    lib = check_twin(library, "")
    lib[keys[0]]  # an unknown key raises EntryNotFound, naming the valid ones
    cert = lib.certificate
    spec = CertifySpec.from_json(cert.spec_json) if cert is not None else library_spec(lib)
    if video is not None:
        from skatelib.pipeline.build.preflight import check_output

        check_output(video, [library], what="video")
    draw = make_draw(spec, seed)
    e = draw.errors
    console.print(escape(f"draw {seed}: robot mass x{e.mass_scale:.3f}, payload {e.payload_kg:.2f} kg at "
                         f"{tuple(round(x, 3) for x in e.payload_pos_m)} m, floor mu {e.floor_mu:.3f}, trucks "
                         f"x{e.kb_scale:.3f}, rolling x{e.rolling_scale:.3f}, deck x{e.deck_mass_scale:.3f}, motors "
                         f"x{e.motor_scale:.3f}; shove {draw.shove_Ns:.2f} N s toward "
                         f"{draw.shove_direction_rad:+.2f} rad at {100 * draw.shove_at:.0f} % of the entry"))
    _, verdict = ride_draw(library, keys[0], spec, seed, mpc if changed else None, video)
    if video is not None:
        console.print(escape(f"wrote {video}"))
    note = f"; with {' and '.join(changed)} given: not the certificate's controller" if changed else ""
    if twin_table([verdict], f"draw {seed} of the certificate's distributions ({spec.state} state fed{note})"):
        raise typer.Exit(1)
