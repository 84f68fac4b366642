"""crumple's scene and asset generators, one importable package (standard library only: a bare machine runs them).

Modules: `png` (PNG in and out), `scene` (the pieces scene files share: materials, bodies, writing a scene),
`assets` (the procedural meshes and bump maps of scenes/assets/), `highway`, `crate`, `arch`, `card_house` and
`joints` (the scenes they write). Each generator module has a `main()`; tools/make-*.py run them from the command
line (`--help` on each). Everything written is the same byte for byte on every run.
"""
