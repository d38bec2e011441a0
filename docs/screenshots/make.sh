#!/usr/bin/env bash
# Screenshots of the built site (landing page and the lateral guide) with headless Chromium
# (Debian: apt-get install chromium). Run from the repository root.
set -euo pipefail
site=$(mktemp -d)
mkdocs build -q -d "$site"
for page in "index.html:landing" "guides/lateral/index.html:guide_lateral"; do
  chromium --headless=new --no-sandbox --disable-gpu --hide-scrollbars --window-size=1280,1000 \
    --screenshot="docs/screenshots/${page##*:}.png" "file://$site/${page%%:*}"
done
rm -rf "$site"
