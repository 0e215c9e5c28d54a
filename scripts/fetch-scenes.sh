#!/usr/bin/env bash
# Download the papers' scenes into a scenes root (default: ./scenes), in the layout the
# configs expect (NAME/FILE.obj.gz), verifying the SHA-256 of each OBJ's content.
#
#   scripts/fetch-scenes.sh [SCENES_ROOT] [NAME ...]
#
# Names: stanford-bunny sibenik conference dabrovic-sponza cornell-box utah-teapot
#        fairy-forest san-miguel (these two have no pinned checksum: the script prints the
#        digest it got so you can record it; results on them are marked by their source path).
# Needs: curl, unzip, gzip, sha256sum. Licences: see each archive's README; the scenes are
# never committed to this repository.
set -euo pipefail

root=${1:-scenes}
shift || true
mkdir -p "$root"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

ACJ=https://raw.githubusercontent.com/alecjacobson/common-3d-test-models/8a4f8642acaf43f9cd7b67858a1502e1055ef202/data
MCG=https://github.com/jvm-graphics-labs/awesome-3d-meshes/raw/eaf9cdb69c52c3832683e7333d04f0038f55a0e8/McGuire

# name | url | file inside the archive ("-" for a plain .obj) | output file | sha256 of the .obj
SCENES=(
  "stanford-bunny|$ACJ/stanford-bunny.obj|-|stanford-bunny.obj.gz|1eb35d1e21ce99e5ce911353b6be278990713448dd9e8f5c9387f9de39b32205"
  "utah-teapot|$ACJ/teapot.obj|-|teapot.newell.obj.gz|1b5396fedd74b577e32cef41146582c2f2e1a050d5b4915193c0ac1ad4187ed4"
  "conference|$MCG/Conference%20Room/conference.zip|conference.obj|conference.obj.gz|034a0af3ca60340813c67b3405c84872282e5aa03fd818d26f9b2651f76ea47a"
  "sibenik|$MCG/Sibenik/sibenik.zip|sibenik.obj|sibenik.obj.gz|786134de73f1b40b0975af2e7bd969bc9a07d7411e6ad4ba1e30f3a5bde63bf8"
  "dabrovic-sponza|$MCG/Dabrovic%20Sponza/sponza.zip|sponza.obj|sponza.obj.gz|f109270c87e563790153e557890c1029eea4fda4ce360b4164fa8682627bd90d"
  "cornell-box|$MCG/Cornell%20Box/CornellBox.zip|CornellBox-Original.obj|CornellBox-Original.obj.gz|6e2b8b91590e54005fba03b1847c626ee4d9fd85f754045780e6c0001ada4188"
  "fairy-forest|https://www.sci.utah.edu/~wald/animrep/FairyForest.zip|FairyForest/f000.obj|fairy-forest.obj.gz|-"
  "san-miguel|$MCG/San%20Miguel/San_Miguel.zip|san-miguel.obj|san-miguel.obj.gz|-"
)

want=("$@")
failed=0
for entry in "${SCENES[@]}"; do
  IFS='|' read -r name url inner out sum <<<"$entry"
  if ((${#want[@]})) && [[ ! " ${want[*]} " == *" $name "* ]]; then continue; fi
  dest="$root/$name/$out"
  if [[ -f "$dest" ]]; then echo "$name: $dest exists, skipped"; continue; fi
  echo "$name: downloading $url"
  if ! curl -fL --retry 3 -o "$tmp/dl" "$url"; then
    echo "$name: download failed; fetch it by hand from the archive named in ../shared/scenes/README.md" >&2
    failed=1; continue
  fi
  if [[ "$inner" == "-" ]]; then
    mv "$tmp/dl" "$tmp/scene.obj"
  else
    rm -rf "$tmp/x"; mkdir -p "$tmp/x"
    unzip -q "$tmp/dl" -d "$tmp/x"
    found=$(find "$tmp/x" -path "*$inner" | head -n 1)
    if [[ -z "$found" ]]; then echo "$name: $inner not found in the archive" >&2; failed=1; continue; fi
    mv "$found" "$tmp/scene.obj"
  fi
  got=$(sha256sum "$tmp/scene.obj" | cut -c1-64)
  if [[ "$sum" != "-" && "$got" != "$sum" ]]; then
    echo "$name: checksum mismatch (got $got, expected $sum); not installed" >&2
    failed=1; continue
  fi
  [[ "$sum" == "-" ]] && echo "$name: no pinned checksum; sha256 of the OBJ is $got"
  mkdir -p "$root/$name"
  gzip -9 -c "$tmp/scene.obj" >"$dest"
  echo "$name: installed $dest"
done
exit $failed
