// The one way tests check an engine's error: f must throw squall::Error with `code` and a message
// containing `needle` (a field path, a flag); returns the message.
#pragma once

#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "common/error.h"

namespace squall::test {

inline std::string expect_error(Code code, const std::string& needle, const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    EXPECT_EQ(code_name(e.code()), std::string(code_name(code))) << e.what();
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << "no \"" << needle << "\" in: " << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no error; expected " << code_name(code) << " naming " << needle;
  return "";
}

}  // namespace squall::test
