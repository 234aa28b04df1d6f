#!/usr/bin/env bash
# Regenerate the pictures of README.md and docs/features.md (docs/img/*.png) from real scene runs.
# Run from the repository root after `make demo` has created .venv:  bash docs/make_images.sh
# fea_spur needs CalculiX (`ccx`, Debian/Ubuntu: apt-get install calculix-ccx).
set -euo pipefail
cd "$(dirname "$0")/.."
GEAROPT=${GEAROPT:-.venv/bin/gearopt}   # override to use another install
[ -x "$GEAROPT" ] || { echo "error: $GEAROPT not found; run 'make demo' first" >&2; exit 1; }
command -v ccx >/dev/null 2>&1 || { echo "error: ccx (CalculiX) not found; fea_spur needs it" >&2; exit 1; }

# scene  PNG written by the scene  name under docs/img/
IMAGES=(
  "tca_spur_crowned     bearing_contact.png  tca_contact.png"
  "ltca_helical         ltca_te.png          ltca_te.png"
  "microgeometry_loaded loaded_micro_te.png  loaded_micro_te.png"
  "fea_spur             fea_mesh.png         fea_mesh.png"
)

mkdir -p docs/img
done_scenes=" "
for row in "${IMAGES[@]}"; do
  read -r scene png name <<<"$row"
  if [[ "$done_scenes" != *" $scene "* ]]; then
    echo "== $scene"
    "$GEAROPT" run "problems/$scene.toml" --out "out/$scene" --quiet >/dev/null
    done_scenes+="$scene "
  fi
  cp "out/$scene/$png" "docs/img/$name"
  echo "docs/img/$name <- out/$scene/$png"
done
