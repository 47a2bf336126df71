# Run by cpack (CPACK_PRE_BUILD_SCRIPTS, cmake/install.cmake) on the staged
# files of the .deb before it is packed: what Debian policy asks of a
# package and `cmake --install` does not do. The man pages are compressed
# (gzip -9n, policy 12.1), and /usr/share/doc/ffdkit gets a machine-readable
# copyright file (policy 12.5: the MIT LICENSE and the example meshes'
# licences) and a changelog.gz (policy 12.7; the version has no Debian
# revision: a native package).
if(NOT CPACK_GENERATOR STREQUAL "DEB")
  return()
endif()
set(stage ${CPACK_TEMPORARY_INSTALL_DIRECTORY})
file(GLOB_RECURSE man_pages ${stage}/*/share/man/man1/*.1)
foreach(page ${man_pages})
  execute_process(COMMAND gzip -9nf ${page} RESULT_VARIABLE rc)
  if(rc)
    message(FATAL_ERROR "gzip ${page}: ${rc}")
  endif()
endforeach()

file(GLOB bins ${stage}/*/bin)
list(GET bins 0 bin)
get_filename_component(usr ${bin} DIRECTORY)
set(doc ${usr}/share/doc/${CPACK_PACKAGE_NAME})
file(MAKE_DIRECTORY ${doc})

# copyright: the licence texts indented by one space, blank lines as " ."
file(READ ${CPACK_FFD_SOURCE_DIR}/LICENSE mit)
string(REGEX REPLACE "\n$" "" mit "${mit}")
string(REGEX REPLACE "\n\n" "\n.\n" mit "${mit}")
string(REGEX REPLACE "\n" "\n " mit "${mit}")
file(WRITE ${doc}/copyright
"Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/
Upstream-Name: ffdkit
Comment: The libraries ffdkit links keep their own licences (README.md
 \"Licences\"); the example meshes under /usr/share/ffd/examples come with
 theirs (the README.md and SOURCES.md beside them).

Files: *
Copyright: 2026 the ffdkit developers
License: MIT

Files: usr/share/ffd/examples/*
Copyright: see /usr/share/ffd/examples/*/README.md and pbffd/SOURCES.md
License: public-domain and CC0-1.0 and LGPL-2+
 The Stanford bunny is in the public domain; the cow and the elephant
 (Debian's libcgal-demo) are under CC0 1.0; pbffd/hinge.stl is under the
 LGPL-2+, whose text is /usr/share/common-licenses/LGPL-2 (and
 pbffd/LGPL-2.txt beside it).

License: MIT
 ${mit}
")

string(TIMESTAMP date "%a, %d %b %Y %H:%M:%S +0000" UTC)
file(WRITE ${doc}/changelog
"${CPACK_PACKAGE_NAME} (${CPACK_PACKAGE_VERSION}) unstable; urgency=medium

  * Release ${CPACK_PACKAGE_VERSION}: libffd (shared and static), ffd.h, ffd.pc,
    the CMake package ffd, the ffd command and its man pages, the editor's
    page and the example meshes.

 -- ${CPACK_PACKAGE_CONTACT}  ${date}
")
execute_process(COMMAND gzip -9nf ${doc}/changelog RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "gzip ${doc}/changelog: ${rc}")
endif()
