// Hostile paths, options and interruptions: every case asserts the exit status, the
// message naming the file or option, and that nothing outside the requested outputs
// was touched or left behind (output.hpp, README "Limits"). The absurd values of the
// input files are in the bad-input catalogue of cli_test.cpp.

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "dbbkit/io/escape.hpp"
#include "dbbkit/user_text.hpp"
#include "hostile_strings.hpp"
#include "test_util.hpp"

namespace dbbkit {
namespace {

namespace fs = std::filesystem;

using test::kDataC;
using test::kDesignC;

// A fresh directory per test, removed at the end.
class Hostile : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string t = (fs::temp_directory_path() / "dbbkit-hostile-XXXXXX").string();
    ASSERT_NE(::mkdtemp(t.data()), nullptr);
    dir_ = t;
  }
  void TearDown() override {
    std::error_code ec;
    fs::permissions(dir_, fs::perms::owner_all, ec);
    fs::remove_all(dir_, ec);
  }
  std::string path(const std::string& name) const { return (fs::path(dir_) / name).string(); }
  void write(const std::string& name, const std::string& content) const {
    std::ofstream(path(name)) << content;
  }
  // Names in the directory, sorted.
  std::vector<std::string> listing() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_))
      names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
  // No temporary of an output (".NAME.dbbkit-XXXXXX") is left in the directory.
  bool no_temporaries() const {
    for (const std::string& n : listing()) {
      if (n.find(".dbbkit-") != std::string::npos) return false;
    }
    return true;
  }
  std::string dir_;
};

TEST_F(Hostile, AnInputAtTheTemporaryNameIsNeitherReadAsOutputNorDestroyed) {
  fs::copy_file(kDesignC, path("x.json.tmp"));
  const CliRun r =
      run_cli("evaluate --quiet --design " + path("x.json.tmp") + " --out " + path("x.json"));
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(slurp(path("x.json.tmp")), slurp(kDesignC));
  EXPECT_TRUE(nlohmann::json::parse(slurp(path("x.json"))).is_object());
  EXPECT_TRUE(no_temporaries());
}

TEST_F(Hostile, ASymlinkPlantedAtTheOldTemporaryNameIsNotWrittenThrough) {
  write("victim", "keep me\n");
  fs::create_symlink(path("victim"), path("x.json.tmp"));
  const CliRun r = run_cli("evaluate --quiet --design " + kDesignC + " --out " + path("x.json"));
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(slurp(path("victim")), "keep me\n");
  EXPECT_TRUE(fs::is_symlink(path("x.json.tmp")));
  EXPECT_TRUE(no_temporaries());
}

TEST_F(Hostile, AFifoTargetIsRefusedAndStaysAFifo) {
  ASSERT_EQ(::mkfifo(path("f").c_str(), 0600), 0);
  const CliRun r = run_cli("evaluate --quiet --design " + kDesignC + " --out " + path("f"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--out: exists and is not a regular file"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_fifo(path("f")));
  EXPECT_TRUE(no_temporaries());
}

TEST_F(Hostile, ADeviceTargetIsRefusedAndStaysADevice) {
  const CliRun r = run_cli("evaluate --quiet --design " + kDesignC + " --report /dev/null");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("/dev/null: --report: exists and is not a regular file"), std::string::npos)
      << r.err;
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
}

TEST_F(Hostile, ADirectoryTargetAndAMissingDirectoryAreRefused) {
  CliRun r = run_cli("evaluate --quiet --design " + kDesignC + " --out " + dir_);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("is a directory"), std::string::npos) << r.err;
  r = run_cli("evaluate --quiet --design " + kDesignC + " --out " + path("no/such/dir/x.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
  EXPECT_TRUE(listing().empty());
}

TEST_F(Hostile, AReadOnlyDirectoryFailsAndLeavesNothing) {
  // Permissions do not bind root: as root, the command runs as the user nobody (setpriv).
  std::string prefix;
  if (::geteuid() == 0) {
    if (std::system("command -v setpriv > /dev/null") != 0) GTEST_SKIP() << "root without setpriv";
    prefix = "setpriv --reuid=65534 --regid=65534 --clear-groups ";
  }
  fs::permissions(dir_, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                            fs::perms::others_read | fs::perms::others_exec);
  fs::create_directory(path("ro"));
  fs::permissions(path("ro"), fs::perms::owner_read | fs::perms::owner_exec |
                                  fs::perms::group_read | fs::perms::group_exec |
                                  fs::perms::others_read | fs::perms::others_exec);
  const CliRun r = run_cli_shell(prefix + std::string(DBBKIT_CLI) + " evaluate --quiet --design " +
                                 kDesignC + " --out " + path("ro/x.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("cannot create a file in"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_empty(path("ro")));
}

TEST_F(Hostile, AFullStandardOutputIsAnError) {
  for (const std::string& cmd : {"evaluate --design " + kDesignC + " --out -",
                                 "identify --design " + kDesignC + " --data " + kDataC}) {
    const CliRun r = run_cli_shell("(" + std::string(DBBKIT_CLI) + " " + cmd + " > /dev/full)");
    EXPECT_EQ(r.status, 2) << cmd;
    EXPECT_NE(r.err.find("standard output: cannot write"), std::string::npos) << r.err;
  }
}

TEST_F(Hostile, OneFileForTwoOutputsAndAnEmptyPathAreRefused) {
  CliRun r =
      run_cli("evaluate --design " + kDesignC + " --out " + path("x") + " --report " + path("x"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("the same file is the target of two outputs"), std::string::npos) << r.err;
  r = run_cli("evaluate --design " + kDesignC + " --out ''");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--out: an empty path"), std::string::npos) << r.err;
  r = run_cli("identify --design '' --data " + kDataC);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--design: an empty path"), std::string::npos) << r.err;
  EXPECT_TRUE(listing().empty());
}

TEST_F(Hostile, AReportThatFailsLateLeavesNoOutputAndTheOldFileIntact) {
  // gnuplot not on PATH: the report fails after the result is computed. The JSON asked
  // for beside it must not be written, and the file it would replace must stay as it was.
  write("x.json", "old\n");
  const CliRun r =
      run_cli_shell("PATH=/nonexistent " + std::string(DBBKIT_CLI) + " identify --quiet --design " +
                    kDesignC + " --data " + kDataC + " --out " + path("x.json") + " --summary " +
                    path("s.md") + " --report " + path("r.html"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("gnuplot"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(path("x.json")), "old\n");
  EXPECT_EQ(listing(), std::vector<std::string>{"x.json"});
}

TEST_F(Hostile, AnInterruptedRunLeavesNoTemporaryAnywhere) {
  // TERM at several moments of a run that computes, draws plots (gnuplot temporaries)
  // and writes three outputs. Whatever the moment, no temporary is left in the output
  // directory or in TMPDIR, and an output that exists is complete.
  fs::create_directory(path("tmp"));
  fs::create_directory(path("out"));
  for (const char* delay : {"0.05", "0.3", "0.6", "1.0", "1.5"}) {
    const std::string cmd =
        "TMPDIR=" + path("tmp") + " " + std::string(DBBKIT_CLI) + " evaluate --quiet --design " +
        kDesignC + " --monte-carlo --mc-max-trials 400000 --mc-threads 1 --out " +
        path("out/e.json") + " --report " + path("out/e.html") + " --summary " + path("out/e.md") +
        " & p=$!; sleep " + delay + "; kill -TERM $p 2>/dev/null; wait $p";
    run_cli_shell(cmd);
    EXPECT_TRUE(fs::is_empty(path("tmp"))) << "after " << delay << " s";
    for (const auto& e : fs::directory_iterator(path("out"))) {
      const std::string n = e.path().filename().string();
      EXPECT_EQ(n.find(".dbbkit-"), std::string::npos) << n << " after " << delay << " s";
      if (n == "e.json") EXPECT_TRUE(nlohmann::json::parse(slurp(e.path().string())).is_object());
    }
  }
}

// Text is data (architecture.md): the admitted hostile strings as the design's name, its
// description, an installation's description, an assumption and the kit's name reach every
// writer, and each writer carries them as data. The refused ones end at the reader.
TEST_F(Hostile, EveryWriterCarriesHostileNamesAsData) {
  std::string name, text;
  for (const auto& h : test::hostile_strings()) {
    if (!h.admitted) continue;
    text += (text.empty() ? "" : " ") + h.text;
  }
  name = text.substr(0, 150);
  while (!name.empty() && (static_cast<unsigned char>(name.back()) & 0xC0) == 0x80) name.pop_back();
  if (!name.empty() && static_cast<unsigned char>(name.back()) >= 0xC0) name.pop_back();
  nlohmann::json d =
      nlohmann::json::parse(slurp(test::source_path("designs/c-turntable-kit-optimized.json")));
  d["name"] = name;
  d["description"] = text;
  d["assumed"] = {{name, text}};
  d["installations"][0]["description"] = text;
  write("d.json", d.dump());
  nlohmann::json k =
      nlohmann::json::parse(slurp(test::source_path("tests/fuzz/corpus/kit/small_c.json")));
  k["name"] = name;
  write("k.json", k.dump());
  // A file name with an escape, a quote, markup and an invalid byte, for the JUnit report.
  fs::copy_file(path("d.json"), path("zz\x1b'<&\xff.json"));
  const std::string cd = "cd " + dir_ + " && " + std::string(DBBKIT_CLI) + " ";
  const std::string truth = test::source_path("tests/data/truth_length_offset_2r.json");
  for (const std::string& cmd : std::vector<std::string>{
           "evaluate --quiet --design d.json --out e.json --report e.html --summary e.md",
           "simulate --design d.json --truth " + truth + " --out m.csv",
           "identify --quiet --design d.json --data m.csv --out i.json --report i.html --summary "
           "i.md",
           "diagnose --quiet --design d.json --data m.csv --out g.json --report g.html --summary "
           "g.md",
           std::string("program --quiet --design d.json --dialect iso --out p.nc"),
           std::string("program --quiet --design d.json --dialect heidenhain --out p.h"),
           std::string("setup-sheet --quiet --design d.json --report s.html --summary s.md"),
           "optimize --quiet --kit k.json --out o.json --report o.html --summary o.md",
           std::string("bench d.json zz* --junit j.xml --summary b.md")}) {
    const CliRun r = run_cli_shell(cd + cmd);
    EXPECT_TRUE(r.status == 0 || (r.status == 1 && cmd.rfind("bench", 0) == 0)) << cmd << "\n"
                                                                                << r.err;
    EXPECT_EQ(r.err.find('\x1b'), std::string::npos) << cmd;
    EXPECT_EQ(r.out.find('\x1b'), std::string::npos) << cmd;
  }
  EXPECT_FALSE(fs::exists(path("PWNED")));
  for (const char* html : {"e.html", "i.html", "g.html", "s.html", "o.html"}) {
    const std::string h = slurp(path(html));
    ASSERT_FALSE(h.empty()) << html;
    // The one script is the page's self-check; no element of the name became markup.
    size_t scripts = 0;
    for (size_t at = h.find("<script"); at != std::string::npos; at = h.find("<script", at + 1))
      ++scripts;
    EXPECT_EQ(scripts, 1u) << html;
    EXPECT_EQ(h.find("<img"), std::string::npos) << html;
    EXPECT_NE(h.find("&lt;script&gt;alert(1)&lt;/script&gt;"), std::string::npos) << html;
  }
  for (const char* md : {"e.md", "i.md", "g.md", "s.md", "o.md", "b.md"}) {
    // Outside code blocks (text inside a fenced block is shown as it is, never as markup).
    std::string m;
    {
      std::istringstream in(slurp(path(md)));
      std::string fence;
      for (std::string line; std::getline(in, line);) {
        const size_t ticks = line.find_first_not_of('`');
        if (line.rfind("```", 0) == 0) {
          if (fence.empty()) {
            fence = line.substr(0, ticks);
          } else if (line.substr(0, ticks) == fence) {
            fence.clear();
          }
          continue;
        }
        if (fence.empty()) m += line + "\n";
      }
      EXPECT_TRUE(fence.empty()) << md << ": a code block is left open";
    }
    ASSERT_FALSE(m.empty()) << md;
    for (const char* tag : {"<script", "<img", "</script"}) {
      for (size_t at = m.find(tag); at != std::string::npos; at = m.find(tag, at + 1))
        EXPECT_TRUE(at > 0 && m[at - 1] == '\\') << md << " at " << at;
    }
    EXPECT_EQ(m.find("](javascript"), std::string::npos) << md;
    EXPECT_EQ(m.find('\x1b'), std::string::npos) << md;
  }
  // The programs: printable ASCII, one comment per line at most and closed on it, % only as
  // the ISO record's start and end, every line short enough for a control.
  for (const char* prog : {"p.nc", "p.h"}) {
    std::istringstream in(slurp(path(prog)));
    int n = 0, percent = 0;
    for (std::string line; std::getline(in, line); ++n) {
      for (char c : line) EXPECT_TRUE(c >= 0x20 && c < 0x7F) << prog << " line " << n + 1;
      EXPECT_LE(line.size(), io::kProgramLine) << prog << " line " << n + 1;
      if (line == "%") {
        ++percent;
        continue;
      }
      EXPECT_EQ(line.find('%'), std::string::npos) << prog << " line " << n + 1 << ": " << line;
      const size_t open = line.find('(');
      if (prog == std::string("p.nc") && open != std::string::npos) {
        EXPECT_EQ(line.find('(', open + 1), std::string::npos) << line;
        EXPECT_EQ(line.find(')'), line.size() - 1) << line;
      }
      if (prog == std::string("p.h")) {
        const size_t semi = line.find(';');
        if (semi != std::string::npos)
          EXPECT_EQ(line.find(';', semi + 1), std::string::npos) << line;
      }
    }
    EXPECT_GT(n, 50) << prog;
    EXPECT_EQ(percent, prog == std::string("p.nc") ? 2 : 0) << prog;
  }
  // The JUnit report parses as XML 1.0.
  const CliRun x = run_cli_shell("python3 -c \"import xml.etree.ElementTree as E; E.parse('" +
                                 path("j.xml") + "')\"");
  EXPECT_EQ(x.status, 0) << x.err;
  // The readings carry the ids alone: a CSV with no text of the name.
  EXPECT_EQ(slurp(path("m.csv")).find("script"), std::string::npos);
}

TEST_F(Hostile, TextNoWriterCouldCarryIsRefusedAtTheReader) {
  const nlohmann::json base = nlohmann::json::parse(slurp(kDesignC));
  for (const auto& h : test::hostile_strings()) {
    if (h.admitted) continue;
    for (const char* key : {"name", "description", "id"}) {
      nlohmann::json d = base;
      if (std::string(key) == "id") {
        d["installations"][0]["id"] = h.text;
      } else {
        d[key] = h.text;
      }
      // A JSON string holds only valid UTF-8 (nlohmann escapes the controls); invalid
      // bytes are written into the file as they are, in place of a marker.
      std::string text;
      try {
        text = d.dump();
      } catch (const nlohmann::json::type_error&) {
        nlohmann::json marked = d;
        if (std::string(key) == "id") {
          marked["installations"][0]["id"] = "@@@";
        } else {
          marked[key] = "@@@";
        }
        text = marked.dump();
        text.replace(text.find("@@@"), 3, h.text);
      }
      const bool utf8 = !text_problem(h.text, h.text.size()) ||
                        text_problem(h.text, h.text.size())->find("UTF-8") == std::string::npos;
      write("bad.json", text);
      const CliRun r = run_cli("evaluate --quiet --design " + path("bad.json") + " --report " +
                               path("r.html") + " --summary " + path("r.md"));
      EXPECT_EQ(r.status, 2) << h.label << " as " << key << ": " << r.err;
      EXPECT_NE(r.err.find("bad.json"), std::string::npos) << h.label;
      // Bytes that are not UTF-8 are not JSON: the parser names the line and column.
      EXPECT_NE(r.err.find(utf8 ? std::string(key) : "line 1, column"), std::string::npos)
          << h.label << " as " << key << ": " << r.err;
      EXPECT_LT(r.err.size(), 1000u) << h.label;
      for (char c : r.err)
        EXPECT_TRUE(c == '\n' || static_cast<unsigned char>(c) >= 0x20) << h.label;
      EXPECT_FALSE(fs::exists(path("r.html")));
      EXPECT_FALSE(fs::exists(path("PWNED")));
      fs::remove(path("r.html"));
    }
  }
}

// Resources bounded before they are spent: a JSON input beyond 64 MiB is refused unread (a
// 200 MB design used to abort with bad_alloc, exit 134); an unusable TMPDIR is named (it was an
// internal error, exit 3); a program that would command more than 200,000 positions is refused
// naming the option (200 installations at a fine tolerance wrote 219 MB).
TEST_F(Hostile, ResourcesAreBoundedBeforeTheyAreSpent) {
  {
    std::ofstream f(path("big.json"));
    f << "{\"format\": \"dbbkit.design/1\", \"name\": \"";
    f << std::string(65u << 20, 'x') << "\"}";
  }
  CliRun r = run_cli("evaluate --quiet --design " + path("big.json"));
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("big.json: more than the 64 MiB of JSON"), std::string::npos) << r.err;
  fs::remove(path("big.json"));

  r = run_cli_shell("TMPDIR=" + path("no-such-dir") + " " + std::string(DBBKIT_CLI) +
                    " evaluate --quiet --design " + kDesignC + " --report " + path("r.html"));
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("TMPDIR=" + path("no-such-dir") + " is not one"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(path("r.html")));

  nlohmann::json d =
      nlohmann::json::parse(slurp(test::source_path("designs/c-turntable-kit-optimized.json")));
  nlohmann::json many = nlohmann::json::array();
  for (int k = 0; k < 200; ++k) {
    nlohmann::json in = d["installations"][k % 7];
    in["id"] = "i" + std::to_string(k);
    many.push_back(in);
  }
  d["installations"] = many;
  d.erase("predicted");
  write("many.json", d.dump());
  r = run_cli("program --quiet --dialect iso --design " + path("many.json") +
              " --path-tolerance-mm 0.0001 --out " + path("p.nc"));
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("--path-tolerance-mm: the program would command more than 200000"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(path("p.nc")));
}

// The set-up order keeps a way of setting up a ball position as its first and last bar, not
// as a copy of the order: 1000 bar lengths at one position took 3.95 GB (cubic), now a few MB.
// Run under a 1.5 GB address-space limit (not in the sanitizer build, whose shadow memory
// needs more).
TEST_F(Hostile, ASetUpOfAThousandBarsAtOnePositionRunsUnderAMemoryLimit) {
  nlohmann::json d =
      nlohmann::json::parse(slurp(test::source_path("designs/c-turntable-kit-optimized.json")));
  nlohmann::json many = nlohmann::json::array();
  for (int k = 0; k < 1000; ++k) {
    nlohmann::json in = d["installations"][0];
    in["id"] = "b" + std::to_string(k);
    in["bar_mm"] = 100.0 + 0.1 * k;
    in.erase("bar_parts_mm");
    many.push_back(in);
  }
  d["installations"] = many;
  d["angles_deg"] = {0, 90, 180, 270};
  d.erase("predicted");
  write("bars.json", d.dump());
  const CliRun r = run_cli_shell("ulimit -v 1500000; " + std::string(DBBKIT_CLI) +
                                 " setup-sheet --quiet --design " + path("bars.json") +
                                 " --summary " + path("s.md"));
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(slurp(path("s.md")).find("b999"), std::string::npos);
}

// A design whose following balls leave the kit's travel: the sheet says so without blaming the
// rounding, and the check fails (exit 1); it used to blame the rounding and exit 0.
TEST_F(Hostile, ASetUpOutsideTheTravelFailsTheCheckAndSaysWhy) {
  nlohmann::json d =
      nlohmann::json::parse(slurp(test::source_path("designs/c-turntable-kit-optimized.json")));
  d["installations"][3]["ball_mm"]["L"] = 600.0;
  write("far.json", d.dump());
  const CliRun r = run_cli("setup-sheet --quiet --design " + path("far.json") + " --kit " +
                           test::source_path("designs/kits/c-turntable-kit.json") +
                           " --resolution-mm 0.5 --summary " + path("s.md"));
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("leave the kit's travel as designed"), std::string::npos) << r.err;
  const std::string sheet = slurp(path("s.md"));
  EXPECT_NE(sheet.find("OUTSIDE the kit's travel as designed (not from any rounding): 2r by"),
            std::string::npos)
      << sheet;
}

// A second hostile round: what it found to fail, each refused with its reason or carried.
TEST_F(Hostile, ASecondRoundOfHostileInputsIsRefusedOrCarried) {
  const nlohmann::json base = nlohmann::json::parse(slurp(kDesignC));
  // A file name that is not UTF-8 is written into the JSON with U+FFFD (it crashed the writer).
  fs::copy_file(kDesignC, path("bad\xff.json"));
  CliRun r =
      run_cli("evaluate --quiet --design " + path("bad\xff.json") + " --out " + path("e.json"));
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(slurp(path("e.json")).find("bad\xef\xbf\xbd.json"), std::string::npos);
  // A NUL byte ends nlohmann's parse: what followed was ignored.
  write("nul.json", slurp(kDesignC) + std::string("\0 garbage {{{ \xff", 16));
  r = run_cli("evaluate --quiet --design " + path("nul.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("a NUL byte: not JSON text"), std::string::npos) << r.err;
  // A baseline's keys name files: text, never raw on the terminal.
  write("bl.json", R"({"format": "dbbkit.designs-baseline/1", "tolerance_relative": 0.01,
    "designs": {"x\n\u001b[2J.json": {"rank": 1, "n_unknowns": 1, "worst_std_um": 1}}})");
  r = run_cli("bench " + kDesignC + " --baseline " + path("bl.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("designs: the key 'x\\n\\x1B[2J.json'"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find('\x1b'), std::string::npos);
  // The optimize's design names the kit's path as text its own reader takes back.
  const std::string odd = path("k\nx.json");
  fs::copy_file(test::source_path("tests/fuzz/corpus/kit/small_c.json"), odd);
  r = run_cli_shell(std::string(DBBKIT_CLI) + " optimize --quiet --kit \"$(printf '" + dir_ +
                    "/k\\nx.json')\" --out " + path("o.json"));
  EXPECT_EQ(r.status, 0) << r.err;
  r = run_cli("evaluate --quiet --design " + path("o.json"));
  EXPECT_EQ(r.status, 0) << r.err;
  // Values that cannot be: each refused naming its key and the value.
  struct Bad {
    std::string key;
    nlohmann::json value;
    std::string says;
  };
  for (const Bad& b :
       {Bad{"reference_length_mm", 1e-300, "from 0.001 to 10000 mm, got 1e-300"},
        Bad{"/installations/0/bar_mm", 1e-9, "from 25 mm"},
        Bad{"/instrument", {{"range_mm", 1e-12}}, "from 0.001 mm"},
        Bad{"/instrument", {{"max_drift_um_per_min", 0}}, "must be from 0.001 to 10000 um/min"},
        Bad{"/instrument", {{"max_drift_um_per_min", 1e5}}, "got 100000"}}) {
    nlohmann::json d = base;
    d[nlohmann::json::json_pointer(b.key[0] == '/' ? b.key : "/" + b.key)] = b.value;
    write("v.json", d.dump());
    r = run_cli("evaluate --quiet --design " + path("v.json"));
    EXPECT_EQ(r.status, 2) << b.key;
    EXPECT_NE(r.err.find(b.says), std::string::npos) << b.key << ": " << r.err;
  }
  // Type A on readings the model explains exactly: no uncertainty of 0 (all conformed).
  {
    std::ofstream f(path("zero.csv"));
    f << "installation,angle_deg,reading_um\n";
    for (const auto& in : base["installations"])
      for (int a = 0; a <= 360; a += 20) f << in["id"].get<std::string>() << "," << a << ",0\n";
  }
  r = run_cli("identify --quiet --type-a --design " + kDesignC + " --data " + path("zero.csv") +
              " --tolerances " +
              test::source_path("designs/tolerances/c-turntable-acceptance.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--type-a: the residual is zero"), std::string::npos) << r.err;
  // A range's limit below zero is an empty zone.
  write("t.json", R"({"format": "dbbkit.tolerances/1",
    "limits": [{"quantity": "EXC range", "upper": -1, "unit": "um"}]})");
  r = run_cli("identify --quiet --design " + kDesignC + " --data " + kDataC + " --tolerances " +
              path("t.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("limits[0].upper: EXC range is a range, never negative"), std::string::npos)
      << r.err;
  // Sweeps whose product is too large.
  r = run_cli("evaluate --quiet --design " + kDesignC +
              " --sweep L1=20:300:1 --sweep H1=20:300:1 --sweep L2=20:300:1");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("more than 100000 design points"), std::string::npos) << r.err;
  // A kit's variable with a control character.
  nlohmann::json k =
      nlohmann::json::parse(slurp(test::source_path("tests/fuzz/corpus/kit/small_c.json")));
  k["pattern"] = {
      {"positions", {{{"id", "1"}, {"L", "L\u001b"}, {"H", 45}, {"directions", {"radial"}}}}}};
  write("k.json", k.dump());
  r = run_cli("optimize --quiet --kit " + path("k.json"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("L"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\x1b'), std::string::npos) << r.err;
  // The parser's errors escape what they echo.
  r = run_cli_shell(std::string(DBBKIT_CLI) + " program --design " + kDesignC +
                    " --dialect \"$(printf 'x\\033[2J')\"");
  EXPECT_EQ(r.status, 2);
  EXPECT_EQ(r.err.find('\x1b'), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--dialect"), std::string::npos) << r.err;
  // A gnuplot that fails without a word: its exit status is named.
  fs::create_directory(path("bin"));
  write("bin/gnuplot", "#!/bin/sh\nexit 3\n");
  fs::permissions(path("bin/gnuplot"), fs::perms::owner_all);
  r = run_cli_shell("PATH=" + path("bin") + ":/usr/bin:/bin " + std::string(DBBKIT_CLI) +
                    " evaluate --quiet --design " + kDesignC + " --report " + path("r.html"));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("gnuplot failed (exit status 3, no message)"), std::string::npos) << r.err;
}

// Text of the caller's options reaches a message quoted, its line breaks escaped and cut: the
// message is one line (--effects, --criterion and --sweep wrote theirs raw).
TEST_F(Hostile, TheCallersTextInAMessageIsOneLine) {
  const std::string kit = test::source_path("tests/fuzz/corpus/kit/small_c.json");
  const std::string long_text(5000, 'x');
  for (const std::string& args :
       {"identify --design " + kDesignC + " --data " + kDataC +
            " --effects \"$(printf 'length_offset[1r],a\\nb')\"",
        "identify --design " + kDesignC + " --data " + kDataC +
            " --effects \"$(printf 'centring.q\\nz[1r]')\"",
        "optimize --kit " + kit + " --criterion \"$(printf 'wor\\nst')\"",
        "evaluate --design " + kDesignC + " --sweep \"$(printf 'L1=20:30\\n:5')\"",
        "evaluate --design " + kDesignC + " --sweep \"$(printf 'Lq\\nz=20:30:5')\"",
        "evaluate --design " + kDesignC + " --sweep L1=" + long_text}) {
    const CliRun r = run_cli_shell(std::string(DBBKIT_CLI) + " " + args);
    EXPECT_EQ(r.status, 2) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_LT(r.err.size(), 600u) << r.err;
  }
}

struct OptionCase {
  std::string args;
  std::string message;
};

class HostileOption : public ::testing::TestWithParam<OptionCase> {};

TEST_P(HostileOption, ExitsTwoNamingTheOption) {
  std::string args = GetParam().args;
  for (const auto& [key, value] :
       {std::pair<std::string, std::string>{"{C}", kDesignC},
        {"{data}", kDataC},
        {"{kit}", test::source_path("tests/fuzz/corpus/kit/small_c.json")}}) {
    for (size_t at; (at = args.find(key)) != std::string::npos;)
      args.replace(at, key.size(), value);
  }
  const CliRun r = run_cli(args);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find(GetParam().message), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty());
}

INSTANTIATE_TEST_SUITE_P(
    Catalogue, HostileOption,
    ::testing::Values(
        OptionCase{"optimize --kit {kit} --threads 100000",
                   "--threads: '100000' is outside [0, 256]"},
        OptionCase{"optimize --kit {kit} --threads -3", "--threads: '-3' is outside"},
        OptionCase{"evaluate --design {C} --monte-carlo --mc-threads 100000", "--mc-threads"},
        OptionCase{"diagnose --design {C} --data {data} --level nan",
                   "--level: 'nan' is not a number"},
        OptionCase{"diagnose --design {C} --data {data} --level 0.5", "--level: '0.5' is outside"},
        OptionCase{"diagnose --design {C} --data {data} --max-effects 1e3", "--max-effects"},
        OptionCase{"evaluate --design {C} --reference-length-mm inf", "--reference-length-mm"},
        OptionCase{"evaluate --design {C} --reference-length-mm -5", "--reference-length-mm"},
        OptionCase{"evaluate --design {C} --coverage 1.5", "--coverage"},
        OptionCase{"evaluate --design {C} --coverage nan", "--coverage"},
        OptionCase{"simulate --design {C} --truth {C} --seed -1", "--seed: '-1' is not a seed"},
        OptionCase{"evaluate --design {C} --monte-carlo --mc-seed 0x10", "--mc-seed"},
        OptionCase{
            "evaluate --design {C} --monte-carlo --mc-batch 100000000 --mc-max-trials 100000000",
            "batch_trials: 100000000 trials per batch of 108 values would keep"},
        OptionCase{"evaluate --design {C} --monte-carlo --mc-batch 0", "--mc-batch"},
        OptionCase{"bench {C} --tolerance inf", "--tolerance"},
        OptionCase{"evaluate --design /dev/zero", "/dev/zero: line 1, column 1: a NUL byte"},
        OptionCase{"evaluate --design /tmp", "/tmp: is a directory"}));

}  // namespace
}  // namespace dbbkit
