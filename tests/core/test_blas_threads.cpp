#include "core/blas_threads.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>

namespace brainshift::core {
namespace {

TEST(Blas, TheFactorisationsBlasIsTheOneLinked) {
  // CHOLMOD's supernodal factorisation calls dgemm_, served by the first library of the process
  // that defines it. Debian's Ceres config once put ATLAS's libf77blas there, ahead of whatever
  // BLAS was chosen (cmake/deps/blas.cmake): with OpenBLAS linked, it must be OpenBLAS's.
  const std::string lib = blas_library();
  if (blas_threads() > 0) {
    ASSERT_FALSE(lib.empty()) << "OpenBLAS linked, but no dgemm_ in the process";
    EXPECT_NE(lib.find("openblas"), std::string::npos) << lib;
  } else {  // BS_BLAS=system: whatever the system provides (none if nothing here loads CHOLMOD)
    std::cout << "[ blas ] built without OpenBLAS; dgemm_ from '" << lib << "'\n";
  }
}

TEST(Blas, OneThreadForTheIntraoperativeCommandsUnlessTheUserSaidOtherwise) {
  const int before = blas_threads();
  const bool user_set = std::getenv("OPENBLAS_NUM_THREADS") != nullptr;
  const bool applied = one_blas_thread_unless_set();
  if (before == 0) {  // no OpenBLAS: nothing to set
    EXPECT_FALSE(applied);
    EXPECT_EQ(blas_threads(), 0);
  } else if (user_set) {  // the user's count stands
    EXPECT_FALSE(applied);
    EXPECT_EQ(blas_threads(), before);
  } else {
    EXPECT_TRUE(applied);
    EXPECT_EQ(blas_threads(), 1);
  }
}

}  // namespace
}  // namespace brainshift::core
