#!/usr/bin/env bash
# The HTML reports in a real browser: headless Chromium (installed by
# ./setup.sh --browser when missing) loads each report, renders it to PNG, and
# the page's own self-check must say that every plot is present and holds data,
# that no script error occurred and that nothing was fetched from elsewhere.
# Usage: report_browser_test.sh SOURCE_DIR DBBKIT_CLI
set -euo pipefail
src="$1"
cli="$2"
"$src/setup.sh" --browser
browser="$(command -v chromium || command -v chromium-browser)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cd "$src"

# Each report, with the number of plots it must hold.
"$cli" identify --design designs/paper-c-turntable.json --data tests/data/paper/paper_c_turntable.csv \
  --out "$work/id.json" --report "$work/identify.html" --quiet
"$cli" evaluate --design designs/paper-c-turntable.json --sweep L2=120:250:10 --sweep H3=80:300:20 \
  --report "$work/evaluate.html" --quiet
"$cli" optimize --kit designs/kits/b-head-kit.json --out "$work/best.json" --report "$work/optimize.html" --quiet
"$cli" diagnose --design designs/paper-b-head.json --data tests/data/paper/paper_b_head.csv \
  --out "$work/dg.json" --report "$work/diagnose.html" --quiet
"$cli" setup-sheet --design "$work/best.json" --kit designs/kits/b-head-kit.json --report "$work/setup-sheet.html" --quiet
"$cli" predict --result "$work/id.json" --grid-radius-mm 0,100,200 --grid-height-mm 0,100 --grid-around 8 \
  --report "$work/predict.html" --quiet
# optimize: 3 plots and the best design's set-up sheet, a drawing per installation.
steps="$(grep -c '"id":' "$work/best.json")"
declare -A expected=([identify]=4 [evaluate]=3 [optimize]=$((3 + steps)) [diagnose]=5 [setup-sheet]=$steps
                     [predict]=2)

failed=0
for name in identify evaluate optimize diagnose setup-sheet predict; do
  page="file://$work/$name.html"
  flags=(--headless --no-sandbox --disable-gpu --hide-scrollbars --no-first-run --disable-extensions
         --user-data-dir="$work/profile")
  timeout 120 "$browser" "${flags[@]}" --window-size=1280,4000 --screenshot="$work/$name.png" "$page" \
    >"$work/$name.shot.log" 2>&1 || true
  timeout 120 "$browser" "${flags[@]}" --virtual-time-budget=5000 --dump-dom "$page" \
    >"$work/$name.dom" 2>"$work/$name.dom.log" || true
  check="$(grep -o '<p id="selfcheck"[^>]*>[^<]*' "$work/$name.dom" || true)"
  png_ok=0
  if [ -s "$work/$name.png" ] && [ "$(head -c 8 "$work/$name.png" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ] \
     && [ "$(stat -c %s "$work/$name.png")" -gt 50000 ]; then
    png_ok=1
  fi
  if [[ "$check" == *'data-status="ok"'* ]] && [[ "$check" == *"self-check: ${expected[$name]} plots, 0 empty"* ]] \
     && [ "$png_ok" = 1 ]; then
    echo "ok   $name: ${check##*>} ; PNG $(stat -c %s "$work/$name.png") bytes"
  else
    failed=$((failed + 1))
    echo "FAIL $name: self-check '${check##*>}' (expected ${expected[$name]} plots); PNG ok=$png_ok"
    tail -5 "$work/$name.dom.log" "$work/$name.shot.log" || true
  fi
done
# The check can fail: the same page with the data of its plots taken out must be caught.
sed -e 's/id="gnuplot_plot_/id="removed_plot_/g' "$work/identify.html" > "$work/emptied.html"
timeout 120 "$browser" --headless --no-sandbox --disable-gpu --no-first-run --user-data-dir="$work/profile" \
  --virtual-time-budget=5000 --dump-dom "file://$work/emptied.html" >"$work/emptied.dom" 2>/dev/null || true
if grep -q 'data-status="fail"' "$work/emptied.dom" && grep -q '4 empty' "$work/emptied.dom"; then
  echo "ok   a page whose plots hold no data fails its self-check"
else
  failed=$((failed + 1))
  echo "FAIL the self-check did not catch plots without data: $(grep -o '<p id="selfcheck"[^>]*>[^<]*' "$work/emptied.dom")"
fi
[ "$failed" = 0 ]
