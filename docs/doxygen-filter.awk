# Input filter for Doxygen (docs/Doxyfile.in): the public headers document
# themselves in plain // comments, written to be read in the header. This
# turns them into Doxygen comments without editing the headers, line for line
# (line numbers stay those of the header):
#   - a comment line before a declaration          -> ///  (documents what follows)
#   - a comment after code on the same line        -> ///< (documents that member)
#   - a comment line indented deeper than the code
#     above it, continuing a trailing comment      -> ///<
#   - the `#pragma once` after a header's opening
#     comment                                      -> \file (the comment documents the file)
# Characters that mean something to Doxygen are escaped in comment text
# (\ @ < > # & and %), so that the prose stays prose: a comment such as
# "<name>_rate" or "#include" must not become an HTML tag or a command.
function escape(text) {
  gsub(/\\/, "\\\\", text)
  gsub(/@/, "\\@", text)
  gsub(/</, "\\<", text)
  gsub(/>/, "\\>", text)
  gsub(/#/, "\\#", text)
  gsub(/&/, "\\\\\\&", text)
  gsub(/%/, "\\%", text)
  return text
}
{
  line = $0
  if (line ~ /^#pragma once/) { print "/// \\file"; trailing = 0; next }
  if (match(line, /^[ \t]*\/\/+/)) {
    # A whole-line comment.
    lead = substr(line, 1, RLENGTH)
    text = substr(line, RLENGTH + 1)
    indent = match(line, /\//) - 1
    if (trailing && indent > code_indent) { marker = "///<" } else { marker = "///"; trailing = 0 }
    sub(/\/+$/, "", lead)
    print lead marker escape(text)
    next
  }
  # Code, possibly with a trailing comment: the first // outside a string
  # literal (an even number of double quotes before it) after some code.
  code_indent = match(line, /[^ \t]/) - 1
  trailing = 0
  from = 1
  while ((at = index(substr(line, from), "//")) > 0) {
    start = from + at - 1
    before = substr(line, 1, start - 1)
    quotes = gsub(/"/, "\"", before)
    if (quotes % 2 == 0 && substr(line, start + 2, 1) != "/" && before ~ /[^ \t]/) {
      print substr(line, 1, start - 1) "///<" escape(substr(line, start + 2))
      trailing = 1
      next
    }
    from = start + 2
  }
  print line
}
