// Browsers refuse this site's module scripts and data requests from file://: say so on
// the page (otherwise only the console tells) and how to serve the folder instead. A
// classic script, not a module, so that it runs from file:// too.
if (location.protocol === "file:") {
  document.addEventListener("DOMContentLoaded", () => {
    const folder = decodeURIComponent(location.pathname.replace(/[^/]*$/, ""));
    const note = document.createElement("div");
    note.id = "file-protocol";
    note.className = "warning";
    note.textContent = "This page was opened from a file, and most browsers do not load its scripts and data from " +
      "file://. Serve the folder and open it over http: python -m http.server --directory \"" + folder +
      "\" 8000, then http://localhost:8000/" + location.pathname.split("/").pop() + " (or build and serve in " +
      "one step: python -m leaderboard.site --results DIR --out SITE --serve).";
    document.body.prepend(note);
  });
}
