#include "core/blas_threads.hpp"

#include <cstdlib>
#include <dlfcn.h>

#if defined(BRAINSHIFT_HAVE_OPENBLAS)
extern "C" {
int openblas_get_num_threads(void);
void openblas_set_num_threads(int num_threads);
}
#endif

namespace brainshift::core {

std::string blas_library() {
  void* f = dlsym(RTLD_DEFAULT, "dgemm_");
  Dl_info info{};
  if (f == nullptr || dladdr(f, &info) == 0 || info.dli_fname == nullptr) return {};
  return info.dli_fname;
}

int blas_threads() {
#if defined(BRAINSHIFT_HAVE_OPENBLAS)
  return openblas_get_num_threads();
#else
  return 0;
#endif
}

bool one_blas_thread_unless_set() {
#if defined(BRAINSHIFT_HAVE_OPENBLAS)
  if (std::getenv("OPENBLAS_NUM_THREADS") != nullptr) return false;
  openblas_set_num_threads(1);
  return true;
#else
  return false;
#endif
}

}  // namespace brainshift::core
