#include "client/transition_csv.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

namespace excite::client {
namespace {

using ::testing::HasSubstr;

// Two states, one input: 5 numbers per row, 6 with a sequence.
absl::StatusOr<std::vector<v1::Transition>> Parse(const std::string& text,
                                                  CsvHeader header = CsvHeader::kAuto) {
  return ParseTransitionCsv(text, 2, 1, 100, header);
}

void ExpectError(const std::string& text, const std::string& what,
                 CsvHeader header = CsvHeader::kAuto) {
  const auto parsed = Parse(text, header);
  ASSERT_FALSE(parsed.ok()) << text;
  EXPECT_EQ(parsed.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(parsed.status().message()), HasSubstr(what)) << parsed.status();
}

TEST(TransitionCsvTest, WhatExciteSimWritesReadsBackExactly) {
  v1::Transition t;
  t.add_state(0.1);
  t.add_state(-1.0 / 3.0);
  t.add_input(2.5e-7);
  t.add_next_state(1e300);
  t.add_next_state(-0.0);
  t.set_sequence(41);
  const std::string text = TransitionCsvHeader(2, 1) + "\n" + TransitionCsvRow(t) + "\n";
  EXPECT_EQ(TransitionCsvHeader(2, 1), "x0,x1,u0,x0_next,x1_next,sequence");
  EXPECT_EQ(TransitionCsvHeader(2, 1, {"theta", "omega"}, {"tau"}),
            "theta,omega,tau,theta_next,omega_next,sequence");
  EXPECT_EQ(TransitionCsvHeader(2, 1, {"theta"}, {"tau"}),  // not one per dimension
            "x0,x1,u0,x0_next,x1_next,sequence");
  const auto parsed = Parse(text);
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  ASSERT_EQ(parsed->size(), 1u);
  EXPECT_EQ((*parsed)[0].SerializeAsString(), t.SerializeAsString());
}

TEST(TransitionCsvTest, RowsWithoutSequenceAreNumberedAfterTheSession) {
  const auto parsed = Parse(
      "theta,omega,u,theta_next,omega_next\n# a comment\n\n"
      "1,2,3,4,5\n 6 , 7 ,8,9,10\n");
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  ASSERT_EQ(parsed->size(), 2u);
  EXPECT_EQ((*parsed)[0].sequence(), 100);
  EXPECT_EQ((*parsed)[1].sequence(), 101);
  EXPECT_EQ((*parsed)[1].state(1), 7.0);
}

TEST(TransitionCsvTest, AMistypedNumberInTheFirstRowIsAnErrorNotAHeader) {
  // The letter O for a zero: was skipped as a header before.
  ExpectError("0.1,0.2,O.5,0.1,0.2\n1,2,3,4,5\n2,3,4,5,6\n",
              "line 1, column 3: \"O.5\" is not a finite number");
  ExpectError("1,2,3,4,5\n1,2,x,4,5\n", "line 2, column 3");
  ExpectError("1,2,3,4,nan\n", "\"nan\" is not a finite number");
}

TEST(TransitionCsvTest, SpacesInsteadOfCommasAreSaid) {
  ExpectError("0.1 0.2 0.5 0.1 0.2\n", "line 1: want 5 comma-separated numbers");
  ExpectError("0.1 0.2 0.5 0.1 0.2\n", "separate them by commas");
}

TEST(TransitionCsvTest, NoTransitionIsAnError) {
  ExpectError("", "no transitions");
  ExpectError("x0,x1,u0,x0_next,x1_next\n# only a header\n", "no transitions");
}

TEST(TransitionCsvTest, SequencesAreIntegersAndEachOnce) {
  ExpectError("1,2,3,4,5,0.5\n", "line 1: the sequence number \"0.5\" is not an integer");
  ExpectError("1,2,3,4,5,-1\n", "is not an integer >= 0");
  ExpectError("1,2,3,4,5,7\n1,2,3,4,5,8\n\n1,2,3,4,5,7\n",
              "line 4: sequence number 7 is also on line 1");
  // Numbered rows after unnumbered ones can collide too: said the same way.
  ExpectError("1,2,3,4,5\n1,2,3,4,5,100\n",
              "line 2: sequence number 100 is also on line 1");
}

TEST(TransitionCsvTest, TheHeaderModeIsTheCallersToOverride) {
  // yes: the first row is skipped whatever it holds (a numeric header).
  const auto yes = Parse("1,2,3,4,5\n6,7,8,9,10\n", CsvHeader::kYes);
  ASSERT_TRUE(yes.ok()) << yes.status();
  EXPECT_EQ(yes->size(), 1u);
  // no: a row of names is data, so an error.
  ExpectError("a,b,c,d,e\n1,2,3,4,5\n", "line 1, column 1", CsvHeader::kNo);
  // A header with the wrong number of columns says so.
  ExpectError("x0,x1,u0\n1,2,3,4,5\n", "line 1: the header has 3 columns");
  EXPECT_FALSE(ParseCsvHeaderMode("maybe").ok());
  EXPECT_EQ(*ParseCsvHeaderMode("no"), CsvHeader::kNo);
}

}  // namespace
}  // namespace excite::client
