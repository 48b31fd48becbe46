#include <gtest/gtest.h>

#include "vmsim/common/errors.hpp"

TEST(LocatedMessage, NamesFileLineAndColumn) {
  EXPECT_EQ(vmsim::located_message("a.apt", 12, 5, "bad word"), "a.apt:12:5: bad word");
  EXPECT_EQ(vmsim::located_message("a.apt", 12, 0, "bad word"), "a.apt:12: bad word");
  EXPECT_EQ(vmsim::located_message("a.apt", 0, 0, "empty"), "a.apt: empty");
}
