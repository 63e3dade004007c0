# AMHMVS_SANITIZERS: a -fsanitize list (e.g. "address,undefined") applied to
# every target of this build. Findings abort (-fno-sanitize-recover), so a
# test with undefined behaviour fails instead of printing a warning.
set(AMHMVS_SANITIZERS "" CACHE STRING "Sanitizers for every target, e.g. address,undefined")
if(AMHMVS_SANITIZERS)
  add_compile_options(-fsanitize=${AMHMVS_SANITIZERS} -fno-sanitize-recover=all
                      -fno-omit-frame-pointer -g)
  add_link_options(-fsanitize=${AMHMVS_SANITIZERS})
  message(STATUS "amhmvs: sanitizers ${AMHMVS_SANITIZERS}")
endif()
