#!/usr/bin/env bash
# Prints "FILE:LINE NAME LINES" for every function body in the C++ files given that is longer than MAX lines
# (from the line of its opening brace to the line of its closing brace), and exits 1 when there is one.
# Usage: function_lengths.sh MAX FILE...
# A function body is a brace block opened at namespace or class scope whose head (the text since the previous
# ';', '{' or '}') holds a parameter list; lambdas and blocks inside a function count as part of it. Comments,
# string and character literals are skipped, so braces inside them do not count.
set -euo pipefail
max=$1
shift
awk -v max="$max" '
function flush_head(c) { head = head c }
BEGIN { bad = 0 }
FNR == 1 { depth = 0; in_block_comment = 0; head = ""; delete kind; delete start; delete name }
{
  line = $0
  n = length(line)
  i = 1
  while (i <= n) {
    c = substr(line, i, 1)
    two = substr(line, i, 2)
    if (in_block_comment) {
      if (two == "*/") { in_block_comment = 0; i += 2; continue }
      i++; continue
    }
    if (two == "//") break
    if (two == "/*") { in_block_comment = 1; i += 2; continue }
    if (c == "\"" || c == "\x27") {
      # raw strings R"( ... )" are not used across lines in this code base; skip to the closing quote
      q = c; i++
      while (i <= n) {
        d = substr(line, i, 1)
        if (d == "\\") { i += 2; continue }
        if (d == q) break
        i++
      }
      i++; head = head "_"; continue
    }
    if (c == "{") {
      outer = (depth == 0) ? "namespace" : kind[depth]
      h = head
      if (h ~ /(^|[^A-Za-z0-9_])namespace([^A-Za-z0-9_]|$)/) k = "namespace"
      else if ((outer == "namespace" || outer == "type") && h ~ /(^|[^A-Za-z0-9_])(class|struct|union|enum)([^A-Za-z0-9_]|$)/ && h !~ /\(/) k = "type"
      else if ((outer == "namespace" || outer == "type") && h ~ /\)/ && h !~ /=[ \t]*$/) k = "function"
      else if (outer == "function" || outer == "inner") k = "inner"
      else k = "data"
      depth++
      kind[depth] = k
      if (k == "function") {
        start[depth] = FNR
        nm = h; gsub(/[ \t\n]+/, " ", nm); sub(/\(.*/, "", nm); sub(/.* /, "", nm)
        name[depth] = nm
      }
      head = ""; i++; continue
    }
    if (c == "}") {
      if (depth > 0) {
        if (kind[depth] == "function") {
          len = FNR - start[depth] + 1
          if (len > max) { printf "%s:%d %s %d lines\n", FILENAME, start[depth], name[depth], len; bad = 1 }
        }
        depth--
      }
      head = ""; i++; continue
    }
    if (c == ";") { head = ""; i++; continue }
    head = head c
    i++
  }
  head = head " "
}
END { exit bad }
' "$@"
