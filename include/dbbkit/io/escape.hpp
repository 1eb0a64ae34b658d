#pragma once
// One escaping function per target (architecture.md, "text is data"): every writer passes
// text it did not write itself (a name, an id, a description, a file name, a message that
// quotes them) through the function of its target, and nothing else turns text into a
// script, a program or markup. The readers refuse what no function can make safe
// (user_text.hpp); these functions make safe whatever reaches them all the same, so a
// string built in code or by Python is no exception.
//
// Each returns valid text of its target for any bytes: an invalid UTF-8 byte and a control
// character (user_text.hpp's list) become U+FFFD in the Unicode targets and '?' in the
// ASCII ones.

#include <cstddef>
#include <string>
#include <string_view>

namespace dbbkit::io {

// HTML and SVG text and attribute values (double or single quoted): & < > " ' as entities.
std::string html_escape(std::string_view s);

// XML 1.0 text and attribute values: html_escape's entities, and only the characters
// XML 1.0 allows (no C0 control but tab, line feed and carriage return; no U+FFFE/FFFF).
std::string xml_escape(std::string_view s);

// Markdown text (CommonMark, GitHub), backslash-escaped where a character could start code
// or markup: < before a letter, / ! or ? (raw HTML, a comment, an autolink); ( or [ after
// ] (a link's or an image's destination or reference) and [ at the start (a link
// definition); ` (code), | (a table cell) and the backslash itself. Emphasis is left as it
// is: it changes the look, never what the text says. A control character becomes a space,
// so a paragraph or a cell stays one. With line_start (a paragraph, a list item's text) a
// character that would open a block where the text starts a line is escaped too: a leading
// # > - + * = _ ~, the . or ) after leading digits (an ordered list), a leading blank (&#32;,
// four of which would open a code block).
std::string markdown_escape(std::string_view s, bool line_start = false);

// A gnuplot string: printable ASCII only (others become '?'), in double quotes with every
// character but letters, digits and " _.,:/+-=" as an octal escape (\047 for '): no quote,
// backquote, macro sign or line break of the text reaches gnuplot's parser.
std::string gnuplot_quote(std::string_view s);
// A label inside a gnuplot data block: printable ASCII without the double quote, for
// "label" fields (the same reason: no line can end the block or start a command).
std::string gnuplot_label(std::string_view s);

// Comment text of a part program, which many controls read as ASCII: printable ASCII only
// (others become '?'); the characters a control reads as structure replaced: ( ) end an
// ISO comment (become [ ]), % ends the record (becomes "pct"), ; starts a comment on some
// controls (becomes ,). At most `max_chars` characters: a longer text is cut and ends in
// "...". The writer breaks a comment into lines of kProgramCommentLine characters, and keeps a
// message on a line of code (a stop, a dwell) to kProgramMessage: no line of a program is
// longer than kProgramLine characters, its block number included.
inline constexpr std::size_t kProgramCommentLine = 64;
inline constexpr std::size_t kProgramMessage = 40;
inline constexpr std::size_t kProgramLine = 80;
std::string program_comment(std::string_view s, std::size_t max_chars);

// Text for a terminal: every control character and invalid byte as an escape (\n, \x1B),
// so no escape sequence reaches it.
std::string terminal_text(std::string_view s);

}  // namespace dbbkit::io
