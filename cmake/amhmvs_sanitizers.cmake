# AMHMVS_SANITIZERS: a -fsanitize list (e.g. "address,undefined") applied to
# every target of this build. Findings abort (-fno-sanitize-recover), so a
# test with undefined behaviour fails instead of printing a warning.
set(AMHMVS_SANITIZERS "" CACHE STRING "Sanitizers for every target, e.g. address,undefined")
if(AMHMVS_SANITIZERS)
  # A report needs file and line only: clang's line tables compile about a
  # quarter quicker than full -g (measured on star_bundle_adjustment.cpp).
  # These options follow the build type's flags, so this -g level wins over
  # RelWithDebInfo's -g.
  set(amhmvs_debug_info -g)
  if(CMAKE_CXX_COMPILER_ID MATCHES Clang)
    set(amhmvs_debug_info -gline-tables-only)
  endif()
  add_compile_options(-fsanitize=${AMHMVS_SANITIZERS} -fno-sanitize-recover=all
                      -fno-omit-frame-pointer ${amhmvs_debug_info})
  add_link_options(-fsanitize=${AMHMVS_SANITIZERS})
  message(STATUS "amhmvs: sanitizers ${AMHMVS_SANITIZERS}")
endif()
