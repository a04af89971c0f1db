#!/usr/bin/env bash
# Screenshots of the built documentation site (make docs first), taken by Debian's headless
# chromium, to look at the site as a reader does:
#
#   bash scripts/docs_screenshot.sh [OUT_DIR] [PAGE ...]
#
# OUT_DIR (default build/docs-screenshots) gets docs-PAGE.png for each PAGE, a path under
# build/docs without .html (default: index getting_started api/clumpprops api/cli results).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${1:-build/docs-screenshots}"
shift || true
PAGES=("$@")
[ ${#PAGES[@]} -gt 0 ] || PAGES=(index getting_started api/clumpprops api/cli results)
SITE="$PWD/build/docs"
[ -f "$SITE/index.html" ] || { echo "no site at $SITE: run make docs first" >&2; exit 1; }
BROWSER=$(command -v chromium || command -v chromium-browser || true)
[ -n "$BROWSER" ] || { echo "chromium is missing: apt-get install chromium" >&2; exit 1; }
mkdir -p "$OUT"
for page in "${PAGES[@]}"; do
  png="$OUT/docs-${page//\//-}.png"
  "$BROWSER" --headless --disable-gpu --no-sandbox --hide-scrollbars --window-size=1280,1600 \
    --screenshot="$png" "file://$SITE/$page.html" >/dev/null 2>&1
  echo "$png"
done
