/* camcmm's shell in the browser (loaded by camcmm.gui.app): a toolbar that fits its width,
   and the keyboard shortcuts.

   Toolbar: the page buttons lose their titles (icons and tooltips stay) while the toolbar
   would not fit with them; the project name truncates last (its tooltip holds it whole).

   Shortcuts (docs/architecture.md, "Keyboard"):
     Alt+1 … Alt+9   the page at that place in the toolbar
     Ctrl+Enter      clicks the visible, enabled [data-shortcut="run"] element (also in a field)
     a single key    clicks the visible, enabled [data-shortcut-key="<key>"] element, unless the
                     focus is in a text field, a select or contenteditable, or a modifier is held
                     (Shift only makes the key itself: "X" is not "x")
     ?               this list; Esc closes it
   An open dialog takes the keys: only elements inside it count. Pages only add the
   attributes; nothing here knows a page. */
(function () {
  "use strict";
  if (window.camcmmShell) return;

  var TOOLBAR = '[data-testid="toolbar"]';
  var PAGES = '[data-testid="page-switch"] [data-page-key]';
  var HELP_ID = "cmm-shortcuts";

  function visible(el) {
    if (!el || !el.isConnected) return false;
    if (typeof el.checkVisibility === "function") {
      return el.checkVisibility({ checkOpacity: true, checkVisibilityCSS: true });
    }
    return el.getClientRects().length > 0;
  }

  function enabled(el) {
    return !(el.disabled || el.getAttribute("aria-disabled") === "true" || el.classList.contains("v-btn--disabled"));
  }

  function openDialog() {
    var help = document.getElementById(HELP_ID);
    if (help) return help;
    var dialogs = document.querySelectorAll(".v-dialog.v-overlay--active .v-overlay__content");
    return dialogs.length ? dialogs[dialogs.length - 1] : null;
  }

  function target(selector) {
    var scope = openDialog();
    var all = Array.prototype.filter.call(document.querySelectorAll(selector), visible);
    if (scope) all = all.filter(function (el) { return scope.contains(el); });
    for (var i = 0; i < all.length; i++) if (enabled(all[i])) return all[i];
    return null;
  }

  var NOT_TEXT = ["button", "checkbox", "radio", "range", "submit", "reset", "file", "color", "image"];

  function typing(el) {
    if (!el || el === document.body || el === document.documentElement) return false;
    if (el.isContentEditable) return true;
    var tag = el.tagName;
    if (tag === "TEXTAREA" || tag === "SELECT") return true;
    if (tag === "INPUT") return NOT_TEXT.indexOf(String(el.type || "text").toLowerCase()) < 0;
    return !!(el.closest && el.closest('[contenteditable=""], [contenteditable="true"], [role="textbox"]'));
  }

  function pageButtons() {
    return Array.prototype.slice.call(document.querySelectorAll(PAGES));
  }

  function describe(el) {
    var text = el.getAttribute("data-shortcut-title") || el.getAttribute("title") || el.getAttribute("aria-label");
    return (text || el.textContent || "").replace(/\s+/g, " ").trim() || "(unnamed control)";
  }

  // -- help --------------------------------------------------------------------------------
  function row(table, keys, what) {
    var tr = document.createElement("tr");
    var k = document.createElement("td");
    var kbd = document.createElement("kbd");
    kbd.textContent = keys;
    k.appendChild(kbd);
    var w = document.createElement("td");
    w.textContent = what;
    tr.appendChild(k);
    tr.appendChild(w);
    table.appendChild(tr);
  }

  function closeHelp() {
    var help = document.getElementById(HELP_ID);
    if (help) help.remove();
  }

  function openHelp() {
    closeHelp();
    var singles = Array.prototype.filter.call(document.querySelectorAll("[data-shortcut-key]"), visible);
    var run = target('[data-shortcut="run"]');
    var back = document.createElement("div");
    back.id = HELP_ID;
    back.setAttribute("data-testid", "shortcut-help");
    back.setAttribute("role", "dialog");
    back.setAttribute("aria-modal", "true");
    back.setAttribute("aria-label", "Keyboard shortcuts");
    var card = document.createElement("div");
    card.className = "cmm-shortcuts-card";
    var title = document.createElement("div");
    title.className = "cmm-shortcuts-title";
    title.textContent = "Keyboard shortcuts";
    card.appendChild(title);
    var table = document.createElement("table");
    pageButtons().slice(0, 9).forEach(function (b, i) {
      row(table, "Alt+" + (i + 1), b.getAttribute("data-page-title") || describe(b));
    });
    row(table, "Ctrl+Enter", run ? "Run: " + describe(run) : "Run (no run button on this page now)");
    var seen = {};
    singles.forEach(function (el) {
      var key = el.getAttribute("data-shortcut-key");
      if (!key || seen[key]) return;
      seen[key] = true;
      row(table, key, describe(el));
    });
    row(table, "?", "this list");
    row(table, "Esc", "close it");
    card.appendChild(table);
    var note = document.createElement("div");
    note.className = "cmm-shortcuts-note";
    note.textContent = "Single keys act outside text fields. Ctrl+Enter works in a field too.";
    card.appendChild(note);
    var close = document.createElement("button");
    close.type = "button";
    close.textContent = "Close";
    close.setAttribute("data-testid", "shortcut-help-close");
    close.addEventListener("click", closeHelp);
    card.appendChild(close);
    back.appendChild(card);
    back.addEventListener("click", function (e) { if (e.target === back) closeHelp(); });
    document.body.appendChild(back);
    close.focus();
  }

  // -- keys --------------------------------------------------------------------------------
  function onKey(e) {
    if (e.defaultPrevented || e.isComposing) return;
    var help = document.getElementById(HELP_ID);
    if (help && (e.key === "Escape" || e.key === "?")) {
      e.preventDefault();
      closeHelp();
      return;
    }
    if (e.altKey && !e.ctrlKey && !e.metaKey && /^Digit[1-9]$/.test(e.code || "")) {
      var buttons = pageButtons();
      var n = Number(e.code.slice(5));
      if (n <= buttons.length && !help) {
        e.preventDefault();
        buttons[n - 1].click();
      }
      return;
    }
    if ((e.ctrlKey || e.metaKey) && !e.altKey && e.key === "Enter") {
      var run = target('[data-shortcut="run"]');
      if (run) {
        e.preventDefault();
        run.click();
      }
      return;
    }
    if (e.ctrlKey || e.metaKey || e.altKey || typing(e.target)) return;
    if (e.key === "?") {
      e.preventDefault();
      openHelp();
      return;
    }
    if (!e.key || e.key.length !== 1 || e.key === " ") return;
    var el = target('[data-shortcut-key="' + (window.CSS && CSS.escape ? CSS.escape(e.key) : e.key) + '"]');
    if (el) {
      e.preventDefault();
      el.click();
    }
  }

  // -- toolbar -----------------------------------------------------------------------------
  var pending = false;

  function fit() {
    pending = false;
    var bar = document.querySelector(TOOLBAR);
    if (!bar) return;
    var content = bar.querySelector(".v-toolbar__content") || bar;
    // measured with the titles shown and the project name at its full width: titles go
    // before the name truncates
    bar.classList.remove("cmm-compact");
    bar.classList.add("cmm-measure");
    var over = content.scrollWidth > content.clientWidth + 1;
    bar.classList.remove("cmm-measure");
    if (over) bar.classList.add("cmm-compact");
  }

  function later() {
    if (pending) return;
    pending = true;
    window.requestAnimationFrame(fit);
  }

  var watched = null;
  var toolbarWatch = new MutationObserver(later);

  function watch() {
    var bar = document.querySelector(TOOLBAR);
    if (bar && bar !== watched) {
      watched = bar;
      toolbarWatch.disconnect();
      // text and children only: the classes fit() sets must not call it again
      toolbarWatch.observe(bar, { childList: true, subtree: true, characterData: true });
      later();
    }
  }

  new MutationObserver(watch).observe(document.documentElement, { childList: true, subtree: true });
  window.addEventListener("resize", later);
  if (document.fonts) {
    document.fonts.addEventListener("loadingdone", later);
    document.fonts.ready.then(later);
  }
  document.addEventListener("keydown", onKey);
  document.addEventListener("click", function (e) {
    var opener = e.target && e.target.closest && e.target.closest("[data-shortcut-help]");
    if (opener) openHelp();
  });
  window.camcmmShell = { fit: fit, help: openHelp, closeHelp: closeHelp };
  watch();
})();
