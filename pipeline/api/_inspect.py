"""A finished build checked against its manifest, summarised and drawn: ``shellvox inspect``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from shellvox.errors import InputError
from shellvox.output import OutputFolder, file_summary, manifest_line, read_manifest, verify_files


@dataclass(frozen=True)
class Inspection:
    """A build, verified (:func:`inspect_build`).

    Attributes
    ----------
    manifest : dict
        The build's ``manifest.json``.
    rows : tuple of (str, str)
        The summary: input, grid, voxel size, origin, each layer's volume, each file
        (verified against its size and SHA-256), the stages' seconds.
    previews : tuple of Path
        The pictures written to ``preview/`` (none when not asked, or without the TIFFs).
    """

    manifest: dict[str, Any]
    rows: tuple[tuple[str, str], ...]
    previews: tuple[Path, ...]

    def __repr__(self) -> str:
        """One line: the build's grid, voxel size, printer and files, and the previews."""
        return f"Inspection({manifest_line(self.manifest)}, previews={len(self.previews)})"


def inspect_build(folder: str | Path, *, previews: bool = True) -> Inspection:
    """Verify every file of a build against its manifest; summarise; draw the previews.

    Parameters
    ----------
    folder : path
        The output folder of a build.
    previews : bool
        Also draw ``preview/*.png`` (sections at true aspect, the outer views, the layer
        depths, halftone slices) from the TIFF stacks; False reads only.

    Returns
    -------
    Inspection

    Raises
    ------
    InputError
        Not a folder, no manifest, a file missing or changed since the build.

    Examples
    --------
    >>> import shellvox
    >>> options = shellvox.BuildOptions(voxel_size_mm=(0.25, 0.25, 0.25), formats=("tiff",))
    >>> built = shellvox.build(shellvox.data.colour_target(), "inspected", options)
    >>> checked = shellvox.inspect_build("inspected")
    >>> checked.rows[2][0], "outer_views.png" in {p.name for p in checked.previews}
    ('grid (z, y, x)', True)
    """
    root = Path(folder)
    if not root.is_dir():
        raise InputError(root, "is not a folder", "give the output folder of a shellvox build")
    if not previews:  # reads only: no lock, so a build on a read-only medium verifies
        manifest = _verified(root)
        return Inspection(manifest, summary_rows(manifest, root), ())
    with OutputFolder(root, outputs=("preview/*.png",), marker=".no-marker") as lock:
        manifest = _verified(root)
        rows = summary_rows(manifest, root)
        if "layers.tif" not in manifest["files"]:
            lock.commit([])
            return Inspection(manifest, rows, ())
        from shellvox.report import write_previews  # the viewer's stack reader: on use

        try:
            written = write_previews(root, manifest)
        except InputError:
            raise
        except (ValueError, OSError, KeyError, IndexError) as error:
            if isinstance(error, OSError) and not isinstance(error, FileNotFoundError):
                raise
            raise InputError(
                root, f"the stack cannot be read ({error})", "rebuild with shellvox build"
            ) from None
        lock.commit(written)
    return Inspection(manifest, rows, tuple(written))


def _verified(folder: Path) -> dict[str, Any]:
    manifest = read_manifest(folder)
    verify_files(folder, manifest)
    return manifest


def summary_rows(manifest: dict[str, Any], folder: Path) -> tuple[tuple[str, str], ...]:
    """Return ``(label, value)`` rows describing a build.

    Raises
    ------
    InputError
        A malformed manifest entry.
    """
    try:
        return tuple(_rows(manifest))
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise InputError(
            folder / "manifest.json",
            f"has a malformed entry ({type(error).__name__}: {error})",
            "rebuild with shellvox build -o " + str(folder),
        ) from None


def _rows(manifest: dict[str, Any]) -> list[tuple[str, str]]:
    grid = manifest["grid"]
    vx, vy, vz = grid["voxel_size_mm"]
    voxel_mm3 = vx * vy * vz
    rows = [
        ("input", f"{manifest['input']['path']} ({manifest['input']['faces']:,} faces)"),
        ("tool", manifest["tool"]),
        ("grid (z, y, x)", " x ".join(f"{n:,}" for n in grid["shape_zyx"])),
        ("voxel (x, y, z)", f"{vx:.4f} x {vy:.4f} x {vz:.4f} mm"),
        ("origin (x, y, z)", ", ".join(f"{v:.3f}" for v in grid["origin_mm"]) + " mm"),
    ]
    for layer in manifest["layers"]:
        volume = layer["voxels"] * voxel_mm3
        rows.append(
            (
                f"layer {layer['index']} {layer['name']}",
                f"{layer['voxels']:,} voxels, {volume:,.1f} mm^3",
            )
        )
    for name, n_files, n_bytes in file_summary(manifest["files"]):
        files = f"{n_files:,} files, " if name.endswith("/") else ""
        rows.append((name, f"{files}{n_bytes:,} bytes, verified"))
    for name, value in manifest["seconds"].items():
        rows.append((f"seconds {name}", f"{value:.2f}"))
    return rows
